"""``swazure camera calibrate`` in a real process: a sensor YAML the other verbs read, figures."""

import subprocess
import sys

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_sensor

from ..conftest import FUZZ
from ..waits import PATIENCE

WIDE = config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml"


def swazure(*args):
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=600,
    )


def test_calibrate_writes_a_sensor_that_evaluate_runs_on(tmp_path):
    out, plot, sheet = tmp_path / "sensor.yaml", tmp_path / "curves.png", tmp_path / "sheet.png"
    run = swazure(
        "camera",
        "calibrate",
        "--camera",
        str(WIDE),
        "--frames",
        "6",
        "--angles",
        "0",
        "30",
        "--out",
        str(out),
        "--plot",
        str(plot),
        "--sheet",
        str(sheet),
        "--quiet",
    )
    assert run.returncode == 0, run.stderr
    assert "ranges (tracking distance, cm)" in run.stdout
    sensor = load_sensor(out)
    assert (
        sensor.noise is not None
        and 3.0 < sensor.sweet_min < sensor.sweet_max < sensor.decaying_max
    )
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and sheet.stat().st_size > 10_000
    evaluate = swazure("evaluate", "--cloud", "sphere:150", "--beta", "0.4", "--sensor", str(out))
    assert evaluate.returncode == 0, evaluate.stderr
    assert "ordered blind pairs" in evaluate.stdout


def test_bad_camera_file_is_one_line_and_exit_2(tmp_path):
    broken = tmp_path / "camera.yaml"
    broken.write_text("fileversion: 1\ncamera: {image: {width: 10}}\n")
    run = swazure("camera", "calibrate", "--camera", str(broken))
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "camera.lens" in run.stderr
    missing = swazure("camera", "calibrate", "--camera", str(tmp_path / "none.yaml"))
    assert missing.returncode == 2 and "no such file" in missing.stderr


def test_fit_needs_a_measured_table():
    run = swazure("camera", "fit", "--camera", str(WIDE))
    assert run.returncode == 2 and "--measured" in run.stderr


def test_output_that_cannot_be_written_is_one_line_and_exit_2(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    run = swazure("camera", "calibrate", "--camera", str(WIDE), "--frames", "1", "--angles", "0",
                  "--out", str(blocker / "sensor.yaml"), "--quiet")  # fmt: skip
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "is not a folder" in run.stderr


def test_calibrate_compares_at_the_measured_distances_themselves(tmp_path):
    from swazure_ros.camera.calibration import sweep
    from swazure_ros.files.sensors import load_camera

    measured = tmp_path / "measured.csv"
    measured.write_text("distance_mm,error_pct,detect_pct\n61,1.0,100\n133,9.0,100\n")
    run = swazure(
        "camera", "calibrate", "--camera", str(WIDE), "--frames", "6", "--angles", "0",
        "--measured", str(measured), "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    printed = {
        int(line.split()[0]): float(line.split()[3])
        for line in run.stdout.splitlines()
        if line.strip().endswith(("yes", "NO")) and line.split()[1] == "mm"
    }
    # Off the sweep's grid (60 distances from 30 mm), so only a render at 61 and
    # 133 mm gives these numbers.
    direct = sweep(load_camera(WIDE), (61.0, 133.0), (0.0,), frames=6, seed=0)
    assert printed == {
        61: round(100 * float(direct.mean_error[0, 0]), 2),
        133: round(100 * float(direct.mean_error[1, 0]), 2),
    }


def test_patterns_prints_each_distance_and_ranks_the_markers(tmp_path):
    plot = tmp_path / "patterns.png"
    run = swazure(
        "camera", "patterns", "--camera", str(WIDE), "--frames", "2", "--distances", "50",
        "110", "--plot", str(plot), "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    rows = [line.split() for line in run.stdout.splitlines() if line.split()[1:2] == ["mm"]]
    assert [row[0] for row in rows] == ["50", "110"]
    # id 0, min, median, max: the 100 markers agree at 50 mm and spread at 110.
    at_50, at_110 = ([float(v) for v in row[2:6]] for row in rows)
    assert at_50[1] == at_50[3] and at_110[3] - at_110[1] > 2.0
    ranked = run.stdout.split("least error on average: ")[1]
    assert ranked.count("id ") == 10
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_calibrate_for_a_swarm_carrying_every_marker(tmp_path):
    out = tmp_path / "sensor.yaml"
    common = ["camera", "calibrate", "--camera", str(WIDE), "--frames", "6", "--angles", "0"]
    run = swazure(*common, "--all-markers", "--out", str(out), "--quiet")
    assert run.returncode == 0, run.stderr
    assert "the 100 markers of DICT_4X4_100 in turn" in run.stdout
    assert "--all-markers" in out.read_text().splitlines()[0]
    plain = swazure(*common, "--out", str(tmp_path / "plain.yaml"), "--quiet")
    assert "(marker 0)" in plain.stdout
    # The decaying error belongs to the patterns: the two sensors' error curves differ.
    mixed, own = load_sensor(out), load_sensor(tmp_path / "plain.yaml")
    assert mixed.noise.mean_error != own.noise.mean_error


@settings(FUZZ, max_examples=60)
@given(data=st.data())
def test_a_generated_camera_file_is_calibrated_or_refused_in_one_line(tmp_path_factory, data):
    """The shipped wide lens's file with one value swapped, through `camera calibrate`:
    a sensor file, or one line and exit 2; never a traceback (issue 55: fy 0 divided)."""
    import contextlib
    import io

    import yaml

    from swazure_ros.cli.main import main
    from swazure_ros.files.reading import config_dir

    from ..files.test_hostile_files import leaves, swapped, values

    original = config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml"
    document = yaml.safe_load(original.read_text())
    where = data.draw(st.sampled_from(leaves(document)))
    folder = tmp_path_factory.mktemp("camera")
    path = folder / "camera.yaml"
    path.write_text(yaml.safe_dump(swapped(document, where, data.draw(values))))
    errors = io.StringIO()
    arguments = ["camera", "calibrate", "--camera", str(path), "--frames", "1", "--angles", "0"]
    with contextlib.redirect_stderr(errors):
        code = main([*arguments, "--quiet", "--out", str(folder / "sensor.yaml")])
    said = errors.getvalue().strip().splitlines()
    if code == 0:
        assert (folder / "sensor.yaml").is_file()
    else:
        assert code == 2 and len(said) == 1 and said[0].startswith("swazure camera: error:"), said
        assert not (folder / "sensor.yaml").exists()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        (("camera", "degradations", "white_level"), -5, "levels must be 0 to 255"),
        (("camera", "degradations", "tone_gamma"), 50.0, "tone_gamma must be 0.1 to 10"),
        (("camera", "marker", "side_mm"), 1e300, "side_mm must be 0.1 to 1000"),
        (("camera", "marker", "side_mm"), 1000.0, "the marker at the closest focus is"),
        (("camera", "image", "fx"), 1e-3, "a sensor's are 0.5 to 50 um"),
        (("camera", "image", "fx"), 1e6, "a sensor's are 0.5 to 50 um"),
        (("camera", "lens", "focus_min_mm"), 3.0, "the marker at the closest focus is"),
        (("camera", "degradations", "residual_blur_px"), 1e6, "residual_blur_px must be"),
    ],
)
def test_camera_values_that_rendering_would_choke_on_are_refused_in_one_line(
    tmp_path, field, value, message
):
    """Each of these once ended in a traceback, a NaN frame or an allocation of gigabytes."""
    import yaml

    from ..files.test_hostile_files import swapped

    original = config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml"
    path = tmp_path / "camera.yaml"
    path.write_text(yaml.safe_dump(swapped(yaml.safe_load(original.read_text()), field, value)))
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "camera", "calibrate", "--camera",
         str(path), "--frames", "1", "--angles", "0", "--quiet"],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert run.returncode == 2 and message in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
