from pathlib import Path

import numpy as np
import pytest

from swazure_ros.core.errors import SensorError
from swazure_ros.core.sensor import (
    BLIND,
    CONTACT,
    DECAYING,
    OUT_OF_RANGE,
    SWEET,
    Sensor,
    load_sensor,
    measured_vectors,
)


def test_default_sensor_file_is_the_published_sensor(sensor):
    loaded = load_sensor()
    assert loaded == Sensor(6.0, 8.0, 8.0, 30.0, sensor.error_coefficients, loaded.name)


def test_classify_boundaries_without_tolerance(sensor):
    tracking = [0.0, 1e-4, 5.999, 6.0, 7.999, 8.0, 29.999, 30.0]
    expected = [CONTACT, BLIND, BLIND, SWEET, SWEET, DECAYING, DECAYING, OUT_OF_RANGE]
    assert sensor.classify(tracking).tolist() == expected


def test_published_error_values(sensor):
    errors = sensor.relative_error([6, 7.6, 8, 15, 30]) * 100
    # The spec states them to three significant digits.
    np.testing.assert_allclose(errors, [1.54, 1.07, 1.09, 10.9, 91.8], rtol=0.005)


def test_measured_vector_keeps_direction_and_has_length_t_prime_plus_2r(sensor):
    points = np.array([[0.0, 0.0, 0.0], [0.0, 8.0, 0.0]])
    vector = measured_vectors(sensor, points, 0.5, [0], [1])[0]
    t = 7.0
    expected_length = t * (1 + sensor.relative_error(t)) + 1.0
    np.testing.assert_allclose(vector, [0.0, expected_length, 0.0], rtol=1e-15)


def test_measured_vectors_are_antisymmetric(sensor):
    points = np.random.default_rng(3).normal(size=(6, 3)) * 10
    forward = measured_vectors(sensor, points, 0.1, [0, 1, 2], [3, 4, 5])
    backward = measured_vectors(sensor, points, 0.1, [3, 4, 5], [0, 1, 2])
    np.testing.assert_array_equal(forward, -backward)


def test_accurate_mode_measures_the_truth(sensor):
    points = np.array([[0.0, 0.0, 0.0], [3.0, 4.0, 12.0]])
    vector = measured_vectors(sensor.error_free(), points, 0.5, [0], [1])[0]
    np.testing.assert_allclose(vector, [3.0, 4.0, 12.0], rtol=1e-15)


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
        (GOOD.replace("sweet_min: 6", "sweet_min: -1"), "sweet_min must be >= 0"),
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
