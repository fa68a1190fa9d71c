"""A camera file as a Camera: what no real camera has is refused in one line naming the key."""

import pytest
import yaml

from swazure_ros.camera.camera_file import camera_from_dict
from swazure_ros.core.errors import SensorError
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera

CAMERAS = config_dir() / "cameras"


def test_camera_file_errors_name_the_key(tmp_path):
    document = yaml.safe_load((CAMERAS / "rpi-camera-module-3-wide.yaml").read_text())
    del document["camera"]["lens"]["f_number"]
    with pytest.raises(SensorError, match="f_number"):
        camera_from_dict(document, "broken.yaml")
    document = yaml.safe_load((CAMERAS / "rpi-camera-module-3-wide.yaml").read_text())
    document["camera"]["marker"]["dictionary"] = "DICT_NOPE"
    with pytest.raises(SensorError, match="DICT_NOPE"):
        camera_from_dict(document, "broken.yaml")
    document["camera"]["marker"]["dictionary"] = "DICT_4X4_100"
    document["camera"]["marker"]["id"] = 100
    with pytest.raises(SensorError, match=r"marker.id 100 is not in DICT_4X4_100 \(0 to 99\)"):
        camera_from_dict(document, "broken.yaml")
    with pytest.raises(SensorError, match="no such camera file"):
        load_camera(tmp_path / "absent.yaml")


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        # fx is bounded by the lens's focal length first: a sensor's pixel.
        ("fx", 1e-300, "focal_length_mm / fx is a pixel of 2.75e+303 um"),
        ("fy", 1e-300, "camera.image: fy must be 1 to 100000 px, got 1e-300"),
        ("cx", 1e300, "camera.image: cx must be 0 to 8192 px (on the image), got 1e+300"),
        ("cy", -5.0, "camera.image: cy must be 0 to 8192 px (on the image), got -5"),
    ],
)
def test_a_camera_file_whose_intrinsics_give_no_finite_pose_is_refused(key, value, message):
    # Issue 66: fx = fy = 1e-300 made the detector's centres NaN; cx = 1e300 did too.
    document = yaml.safe_load((CAMERAS / "rpi-camera-module-3-wide.yaml").read_text())
    document["camera"]["image"][key] = value
    with pytest.raises(SensorError) as refused:
        camera_from_dict(document, "intrinsics.yaml")
    assert str(refused.value).startswith(f"intrinsics.yaml: {message}"), refused.value


@pytest.mark.parametrize("value", ["!!binary AAEC", "!!binary MS41", "[1, 2]", "{a: 1}"])
def test_a_camera_value_of_another_yaml_type_is_one_line_naming_the_key(tmp_path, value):
    # !!binary is bytes: AAEC is no number, and MS41 spells "1.5", which is still not one.
    text = (CAMERAS / "rpi-camera-module-3-wide.yaml").read_text()
    document = yaml.safe_load(text)
    document["camera"]["image"]["fx"] = "SWAP"
    path = tmp_path / "odd.yaml"
    path.write_text(yaml.safe_dump(document).replace("SWAP", value))
    with pytest.raises(
        SensorError, match=r"camera.image.fx must be a finite number, got "
    ) as refused:
        load_camera(path)
    assert "\n" not in str(refused.value)
