from pathlib import Path

import numpy as np
import pytest
import yaml

from swazure_ros.core.errors import SensorError
from swazure_ros.core.sensor_file import sensor_from_dict
from swazure_ros.files.sensors import load_sensor

from .sensors import stochastic


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "sensor.yaml"
    path.write_text(text)
    return path


GOOD = """fileversion: 1
sensor:
  name: test
  ranges: {sweet_min: 6, sweet_max: 8, decaying_min: 8, decaying_max: 30}
  error_model: {kind: none}
"""


def test_sensor_file_round_trip(tmp_path):
    sensor = load_sensor(write(tmp_path, GOOD))
    assert (sensor.sweet_min, sensor.decaying_max, sensor.accurate) == (6.0, 30.0, True)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD.replace("sweet_min: 6", "sweet_min: -1"), "sweet_min must be above 0"),
        (GOOD.replace("sweet_min: 6", "sweet_min: 0"), "sweet_min must be above 0"),
        (GOOD.replace("sweet_max: 8", "sweet_max: 5"), "ranges out of order"),
        (GOOD.replace("decaying_max: 30", "decaying_max: 7"), "ranges out of order"),
        (GOOD.replace("fileversion: 1", "fileversion: 9"), "fileversion 9"),
        (GOOD.replace("decaying_min: 8, ", ""), "missing key 'decaying_min'"),
        (GOOD.replace("kind: none", "kind: magic"), "error_model.kind"),
        ("sensor: [unclosed", "not valid YAML"),
    ],
)
def test_bad_sensor_file_names_the_problem(tmp_path, text, message):
    with pytest.raises(SensorError, match=message):
        load_sensor(write(tmp_path, text))


def test_missing_sensor_file(tmp_path):
    with pytest.raises(SensorError, match="no such sensor file"):
        load_sensor(tmp_path / "absent.yaml")


def test_stochastic_sensor_round_trips_through_yaml(tmp_path):
    import yaml

    sensor = stochastic(seed=9)
    path = tmp_path / "sensor.yaml"
    path.write_text(yaml.safe_dump({"fileversion": 1, "sensor": sensor.to_dict()}))
    assert load_sensor(path) == sensor


def test_stochastic_table_errors_are_one_line(tmp_path):
    import yaml

    document = {"fileversion": 1, "sensor": stochastic().to_dict()}
    document["sensor"]["error_model"]["noise"]["detection"] = [1.0, 1.0]
    path = tmp_path / "sensor.yaml"
    path.write_text(yaml.safe_dump(document))
    with pytest.raises(SensorError, match="one value per tracking_cm"):
        load_sensor(path)


def test_each_fls_carries_its_own_marker_in_a_camera_sensor(tmp_path):
    from dataclasses import replace

    from swazure_ros.camera.aruco import measure_pairs
    from swazure_ros.files.sensors import load_camera

    folder = Path(__file__).resolve().parents[2] / "config" / "cameras"

    def cameras(name):
        return load_camera(folder / name)

    document = yaml.safe_load((folder / "sensor-wide-camera.yaml").read_text())
    assert document["sensor"]["error_model"]["markers"] == "all"
    document["sensor"]["error_model"]["markers"] = [5, 22]
    sensor = sensor_from_dict(document, "sensor.yaml", cameras=cameras)
    assert sensor.camera_markers == (5, 22)
    assert sensor_from_dict(sensor_document(sensor), "again", cameras=cameras) == sensor
    camera = sensor.camera
    # At 100 mm the window reaches the bits, so the pattern shows in the measurement.
    distances, first, second = np.full(2, 100.0), np.array([0, 0]), np.array([2, 3])
    carried = measure_pairs(camera, distances, 7, first, second, markers=(5, 22))
    for row, marker in ((0, 5), (1, 22)):
        alone = measure_pairs(
            replace(camera, marker_id=marker), distances[:1], 7, first[:1], second[row : row + 1]
        )
        np.testing.assert_array_equal(carried[row], alone[0])
    plain = measure_pairs(camera, distances, 7, first, second)
    assert not np.array_equal(carried, plain)
    for markers in ([100], [], "some", [True]):
        document["sensor"]["error_model"]["markers"] = markers
        with pytest.raises(SensorError, match="markers must be 'all' or a list of marker ids"):
            sensor_from_dict(document, "sensor.yaml", cameras=cameras)


def test_a_camera_sensor_without_a_reader_for_its_camera_file_is_refused():
    document = yaml.safe_load(
        (
            Path(__file__).resolve().parents[2] / "config" / "cameras" / "sensor-wide-camera.yaml"
        ).read_text()
    )
    with pytest.raises(SensorError, match="no reader for its camera file"):
        sensor_from_dict(document, "sensor.yaml")


def sensor_document(sensor):
    return {"fileversion": 1, "sensor": sensor.to_dict()}
