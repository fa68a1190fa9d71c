import numpy as np
import pytest

from swazure_ros.core.metrics import (
    alpha_deg,
    describe,
    distance_error_pct,
    phi_error_deg,
    theta_error_deg,
)


def test_distance_error_is_relative_to_the_truth():
    assert distance_error_pct([[2, 0, 0]], [[1, 0, 0]]).tolist() == [100.0]
    assert distance_error_pct([[0, 3, 4]], [[5, 0, 0]]).tolist() == [0.0]


def test_alpha_is_the_angle_between_vectors():
    np.testing.assert_allclose(
        alpha_deg([[1, 0, 0], [1, 1, 0]], [[0, 1, 0], [1, 0, 0]]), [90.0, 45.0]
    )


def test_theta_error_is_the_difference_of_inclinations():
    np.testing.assert_allclose(theta_error_deg([[0, 0, 1]], [[1, 0, 0]]), [90.0])


def test_phi_error_wraps_around():
    estimate = [[np.cos(np.radians(170)), np.sin(np.radians(170)), 0]]
    truth = [[np.cos(np.radians(-170)), np.sin(np.radians(-170)), 0]]
    np.testing.assert_allclose(phi_error_deg(estimate, truth), [20.0])


def test_shape_is_checked():
    with pytest.raises(ValueError, match=r"Expected `estimate` to have shape \(M, 3\)"):
        alpha_deg([1, 2, 3], [[1, 2, 3]])


def test_describe_empty_and_values():
    assert describe([]).mean is None
    stats = describe([1.0, 3.0])
    assert (stats.mean, stats.max, stats.count) == (2.0, 3.0, 2)
