"""The weighted least-squares solve: exact on exact data, the gauge, variances, robustness."""

import numpy as np

from swazure_ros.core.fit_measurements import fit_pairs, measurements, with_outliers
from swazure_ros.core.least_squares import solve
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import ordered_blind_pairs

from .fits import exact, stochastic_sensor, torus_swarm


def test_a_consistent_triangle_is_fit_exactly_and_its_anchor_is_the_origin():
    points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])
    first, second = [0, 1, 2, 1], [1, 2, 0, 0]
    fit = solve(3, exact(first, second, points[second] - points[first]))
    np.testing.assert_allclose(fit.positions, points, atol=1e-12)
    estimate, covariance = fit.relative(np.array([1]), np.array([2]))
    np.testing.assert_allclose(estimate, [[-7.0, 7.0, 0.0]], atol=1e-12)
    assert covariance.shape == (1, 3, 3) and np.all(np.linalg.eigvalsh(covariance) > 0)


def test_two_measurements_of_one_vector_average_and_halve_the_variance():
    fit = solve(2, exact([0, 1], [1, 0], [[7.0, 0, 0], [-7.2, 0, 0]], variance=0.5))
    estimate, covariance = fit.relative(np.array([0]), np.array([1]))
    np.testing.assert_allclose(estimate, [[7.1, 0, 0]])
    np.testing.assert_allclose(covariance[0], np.eye(3) * 0.25)


def test_each_connected_part_has_its_own_gauge_and_no_estimate_crosses_parts():
    # Parts {0, 1} and {2, 3}; FLS 4 is in no measurement.
    fit = solve(5, exact([0, 2], [1, 3], [[7.0, 0, 0], [0, 7.0, 0]]))
    assert fit.part.tolist() == [0, 0, 1, 1, -1]
    np.testing.assert_allclose(fit.positions[[0, 2]], 0.0)
    assert np.isnan(fit.positions[4]).all()
    estimate, covariance = fit.relative(np.array([0, 0, 2]), np.array([1, 2, 3]))
    np.testing.assert_allclose(estimate[[0, 2]], [[7, 0, 0], [0, 7, 0]])
    assert np.isnan(estimate[1]).all() and np.isnan(covariance[1]).all()


def test_the_robust_loss_keeps_turned_vectors_out_and_a_plain_fit_does_not():
    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    flipped = with_outliers(measured, 0.10, 20.0, seed=1)
    turned = (flipped.vectors != measured.vectors).any(axis=1)
    assert 0.07 < turned.mean() < 0.13
    points, size = hood.swarm.points, hood.swarm.size
    source, target = ordered_blind_pairs(hood.pairs)

    def error(fit):
        estimate, _ = fit.relative(source, target)
        return np.nanmean(np.linalg.norm(estimate - (points[target] - points[source]), axis=1))

    clean = error(solve(size, measured))
    robust = error(solve(size, flipped))
    plain = error(solve(size, flipped, robust=False))
    assert robust <= 1.5 * clean < plain
