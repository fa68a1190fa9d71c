import numpy as np
import pytest

from swazure_ros.core.sensor import BLIND, CONTACT, DECAYING, OUT_OF_RANGE, SWEET, Sensor
from swazure_ros.files.sensors import load_sensor

from .sensors import stochastic


def test_default_sensor_file_is_the_published_sensor(sensor):
    loaded = load_sensor()
    assert loaded == Sensor(6.0, 8.0, 8.0, 30.0, sensor.error_coefficients, loaded.name)


def test_classify_boundaries_without_tolerance(sensor):
    tracking = [0.0, 1e-4, 5.999, 6.0, 7.999, 8.0, 29.999, 30.0]
    expected = [CONTACT, BLIND, BLIND, SWEET, SWEET, DECAYING, DECAYING, OUT_OF_RANGE]
    assert sensor.classify(tracking).tolist() == expected


@pytest.mark.parametrize("gap", [False, True])
def test_a_long_array_is_classified_compiled_as_the_masks_classify_it(monkeypatch, gap):
    from swazure_ros.core import sensor as sensor_module

    # A gap between the sweet and decaying ranges: OUT_OF_RANGE between them.
    camera = Sensor(6.0, 8.0, 10.0 if gap else 8.0, 30.0)
    edges = [-1.0, 0.0, 1e-300, 5.999, 6.0, 7.999, 8.0, 9.0, 10.0, 29.999, 30.0, 31.0]
    tracking = np.array([*edges, np.nan, -np.inf, np.inf, *np.linspace(-2, 33, 997)])
    masks = camera.classify(tracking)
    assert masks[0] == CONTACT and masks[7] == (OUT_OF_RANGE if gap else DECAYING)
    monkeypatch.setattr(sensor_module, "COMPILED_CLASSES", 1)
    compiled = camera.classify(tracking)
    np.testing.assert_array_equal(compiled, masks)
    assert compiled.dtype == np.int8


def test_published_error_values(sensor):
    errors = sensor.relative_error([6, 7.6, 8, 15, 30]) * 100
    # The spec states them to three significant digits.
    np.testing.assert_allclose(errors, [1.54, 1.07, 1.09, 10.9, 91.8], rtol=0.005)


def test_stochastic_mean_error_is_the_table_interpolated():
    sensor = stochastic()
    np.testing.assert_allclose(
        sensor.relative_error([5.0, 10.0, 20.0, 40.0]), [0.005, 0.01, 0.11, 0.21]
    )
