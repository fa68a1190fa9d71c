from pathlib import Path

import numpy as np
import pytest

from swazure_ros.core.hop_errors import hop_error, measured_vectors, smallest_hop_error
from swazure_ros.files.sensors import load_sensor

from .sensors import stochastic


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


def ring(count=4000, distance=8.0):
    """FLS 0 at the origin, ``count`` FLSs around it at ``distance`` cm (centres), r = 0.5."""
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    around = np.column_stack(
        [distance * np.cos(angles), distance * np.sin(angles), np.zeros(count)]
    )
    return np.vstack([[0.0, 0.0, 0.0], around])


def test_stochastic_measurement_scatters_around_the_biased_length_as_the_table_says():
    sensor = stochastic(sd=0.02, direction_deg=1.0)
    points = ring()
    others = np.arange(1, len(points))
    vectors = measured_vectors(sensor, points, 0.5, np.zeros_like(others), others)
    tracking = 7.0  # centre distance 8, r = 0.5
    measured = np.linalg.norm(vectors, axis=1) - 1.0
    relative = measured / tracking - 1
    assert np.mean(relative) == pytest.approx(sensor.relative_error(tracking), abs=0.0015)
    assert np.std(relative) == pytest.approx(0.02, rel=0.05)
    truth = points[others] / 8.0
    angle = np.degrees(
        np.arccos(
            np.clip(np.sum(vectors * truth, axis=1) / np.linalg.norm(vectors, axis=1), -1, 1)
        )
    )
    # Two axes of 1 degree each: the angle off the true direction is Rayleigh, mean 1.2533 degrees.
    assert np.mean(angle) == pytest.approx(1.2533, rel=0.05)


def test_stochastic_measurement_of_a_pair_is_the_same_in_any_call_and_order():
    sensor = stochastic(seed=3)
    points = ring(50)
    first = np.zeros(49, dtype=int)
    second = np.arange(1, 50)
    together = measured_vectors(sensor, points, 0.5, first, second)
    reversed_order = measured_vectors(sensor, points, 0.5, first[::-1], second[::-1])[::-1]
    one = measured_vectors(sensor, points, 0.5, [0], [17])
    np.testing.assert_array_equal(together, reversed_order)
    np.testing.assert_array_equal(together[16], one[0])
    other_seed = measured_vectors(stochastic(seed=4), points, 0.5, first, second)
    assert not np.allclose(together, other_seed)


def test_accurate_mode_drops_the_noise_too():
    sensor = stochastic().error_free()
    assert sensor.accurate and sensor.noise is None
    points = ring(10)
    vectors = measured_vectors(sensor, points, 0.5, np.zeros(10, int), np.arange(1, 11))
    np.testing.assert_allclose(vectors, points[1:])


def test_camera_sensor_renders_each_pair_the_same_way_every_time():
    sensor = load_sensor(
        Path(__file__).resolve().parents[2] / "config/cameras/sensor-wide-camera.yaml"
    )
    assert sensor.camera is not None and not sensor.accurate
    points = np.array([[0.0, 0.0, 0.0], [7.0, 1.0, 0.5], [0.0, 12.0, 3.0]])
    first, second = [0, 0, 1], [1, 2, 2]
    vectors = measured_vectors(sensor, points, 0.5, first, second)
    again = measured_vectors(sensor, points, 0.5, first[::-1], second[::-1])[::-1]
    np.testing.assert_array_equal(vectors, again)
    truth = points[second] - points[first]
    # A sweet hop (t = 6.1 cm) within 3 % and half a degree; measured, so not exact.
    assert np.linalg.norm(vectors[0]) == pytest.approx(np.linalg.norm(truth[0]), rel=0.03)
    cosine = vectors[0] @ truth[0] / np.linalg.norm(vectors[0]) / np.linalg.norm(truth[0])
    assert np.degrees(np.arccos(min(cosine, 1.0))) < 0.5
    assert not np.array_equal(vectors, truth)
    assert sensor.error_free().camera is None


def test_hop_error_of_the_published_sensor_is_the_length_error_in_cm(sensor):
    tracking = np.array([6.0, 8.0, 15.0])
    relative = 0.00180987 * tracking**2 - 0.02756392 * tracking + 0.11561755  # spec, section 3
    np.testing.assert_allclose(hop_error(sensor, tracking, 0.5), tracking * relative)
    assert hop_error(sensor.error_free(), [6.0, 8.0], 0.5).tolist() == [0.0, 0.0]


def test_hop_error_of_a_stochastic_sensor_is_the_variance_of_the_hop_vector():
    sensor = stochastic(sd=0.02, direction_deg=1.0)
    points = ring(distance=9.0)  # tracking distance 8 with r = 0.5
    others = np.arange(1, len(points))
    vectors = measured_vectors(sensor, points, 0.5, np.zeros_like(others), others)
    mean = points[others] * (8.0 * (1 + sensor.relative_error(8.0)) + 1.0) / 9.0
    scatter = np.mean(np.sum((vectors - mean) ** 2, axis=1))
    assert hop_error(sensor, [8.0], 0.5)[0] == pytest.approx(scatter, rel=0.08)


def test_smallest_hop_error_bounds_every_hop_from_below(sensor):
    for one in (sensor, stochastic()):
        tracking = np.linspace(one.sweet_min, one.decaying_max, 100_003)
        smallest = smallest_hop_error(one, 0.5)
        assert 0 < smallest <= hop_error(one, tracking, 0.5).min()
        assert smallest > 0.98 * hop_error(one, tracking, 0.5).min()
