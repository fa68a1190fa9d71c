"""bench.camera: render-detect-solve timed, the camera tools' output and a study per sensor."""

from argparse import Namespace

import pytest

from bench.camera import CAMERA_STUDY_SENSORS, camera_section

from .tables import check_shape

pytest.importorskip("cv2", reason="OpenCV (the camera's detector) is not installed")


@pytest.mark.bench_section
def test_the_camera_section_times_a_frame_runs_the_tools_and_a_study(tmp_path):
    published = {"published": CAMERA_STUDY_SENSORS["published"]}
    lines = camera_section(
        Namespace(beta=0.5), distances={"wide": (150,)}, frames=3,
        tool_options=["--frames", "1", "--angles", "0"], study_sensors=published,
        study_options=["--clouds", "torus:200"], records_dir=tmp_path,
    )  # fmt: skip
    timing, study = check_shape(lines)
    [row] = timing[1]
    assert row[:2] == ["wide", "150"] and int(row[2]) > 0 and float(row[5]) > 0
    assert "`wide`: " in " ".join(lines) and "`standard`: " in " ".join(lines)
    assert all(", exit 0" in line for line in lines if line.startswith("`") and " wall, " in line)
    [shape] = study[1]
    assert shape[:2] == ["torus_200", "published"] and int(shape[2].replace(",", "")) > 0
