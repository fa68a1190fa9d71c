"""Refined evaluations: estimates from a fit, honest covariances, path sums without bias."""

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, SWEET_PATH
from swazure_ros.core.fit import (
    CHI2_95_3DOF,
    LEAST_SQUARES,
    LOCAL_LEAST_SQUARES,
    normalized_errors,
    path_estimates,
    refine,
)
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.least_squares import solve
from swazure_ros.core.sensor import Sensor
from swazure_ros.files.cloud_files import load_cloud

from .fits import exact, stochastic_sensor, torus_swarm


@pytest.mark.parametrize("shape", ["torus:120", "helix"])
def test_an_error_free_sensor_s_fit_gives_every_pair_with_a_path_its_truth(shape):
    swarm = torus_swarm(0.3, shape)
    plain = evaluate(swarm, Sensor(6.0, 8.0, 8.0, 30.0), "shortest-length")
    fitted = refine(plain)
    has_path = plain.pairs.status != NO_PATH
    assert has_path.sum() > 1000
    np.testing.assert_allclose(
        fitted.pairs.estimate[has_path], plain.pairs.truth[has_path], atol=1e-7
    )
    assert np.isnan(fitted.pairs.estimate[~has_path]).all()
    assert fitted.summary.fit.estimator == LEAST_SQUARES
    # Statuses and paths are still the policy's.
    np.testing.assert_array_equal(fitted.pairs.status, plain.pairs.status)
    np.testing.assert_array_equal(fitted.pairs.nodes, plain.pairs.nodes)


def test_a_stochastic_sensor_s_fit_beats_its_paths_and_its_covariance_is_honest():
    # A known bias of 3 % the fit removes; the paths carry it. 200 FLSs: the pairs share
    # measurements, so the NEES of a smaller swarm's pairs averages too few independent draws.
    swarm = torus_swarm(0.3, "torus:200")
    plain = evaluate(swarm, stochastic_sensor(mean_error=0.03), "shortest-length")
    fitted = refine(plain)
    sweet = plain.pairs.status == SWEET_PATH
    path_error = plain.pairs.distance_error[sweet].mean()
    assert fitted.pairs.distance_error[sweet].mean() < 0.5 * path_error
    nees = normalized_errors(fitted.pairs.estimate - fitted.pairs.truth, fitted.pairs.covariance)
    known = np.isfinite(nees)
    assert known.sum() == (plain.pairs.status != NO_PATH).sum()
    assert 2.5 <= nees[known].mean() <= 3.5
    assert (nees[known] <= CHI2_95_3DOF).mean() >= 0.93
    assert fitted.summary.fit.consistency.nees.mean == pytest.approx(nees[known].mean())


def test_each_source_s_own_fit_is_exact_on_exact_data_and_honest_on_noisy_data():
    swarm = torus_swarm(0.3, "torus:200")
    exact_run = refine(
        evaluate(swarm, Sensor(6.0, 8.0, 8.0, 30.0), "shortest-length"), LOCAL_LEAST_SQUARES
    )
    has_path = exact_run.pairs.status != NO_PATH
    np.testing.assert_allclose(
        exact_run.pairs.estimate[has_path], exact_run.pairs.truth[has_path], atol=1e-7
    )
    assert exact_run.summary.fit.estimator == LOCAL_LEAST_SQUARES
    assert exact_run.summary.fit.window_flss.max < swarm.size
    plain = evaluate(swarm, stochastic_sensor(mean_error=0.03), "shortest-length")
    local, whole = refine(plain, LOCAL_LEAST_SQUARES), refine(plain)
    sweet = plain.pairs.status == SWEET_PATH
    # What a source hears is less than the whole swarm measures, and far more than one path.
    assert (
        whole.pairs.distance_error[sweet].mean()
        < local.pairs.distance_error[sweet].mean()
        < 0.5 * plain.pairs.distance_error[sweet].mean()
    )
    assert 2.5 <= local.summary.fit.consistency.nees.mean <= 3.5
    assert local.summary.fit.consistency.within_chi2_95_pct >= 93.0


def test_a_pair_beyond_its_source_s_window_gets_its_path_sum_without_the_bias():
    plain = evaluate(torus_swarm(0.3, "torus:200"), stochastic_sensor(0.03), "shortest-length")
    estimate, covariance = path_estimates(plain.hood, plain.pairs)
    has_path = plain.pairs.status != NO_PATH
    # The bias of 3 % is gone (what is left is the 1 % scatter).
    error = np.linalg.norm(estimate - plain.pairs.truth, axis=1)
    biased = np.linalg.norm(plain.pairs.estimate - plain.pairs.truth, axis=1)
    assert error[has_path].mean() < 0.75 * biased[has_path].mean()
    nees = normalized_errors(estimate - plain.pairs.truth, covariance)
    assert 2.5 <= np.nanmean(nees) <= 3.5


def test_a_swarm_with_nothing_to_fit_gets_no_estimates_and_no_error():
    nothing = exact(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros((0, 3)))
    fit = solve(3, nothing)
    assert fit.part.tolist() == [-1, -1, -1] and np.isnan(fit.positions).all()
    sparse_swarm = make_swarm(load_cloud("sphere:20").points, beta=0.01)
    for estimator in (LEAST_SQUARES, LOCAL_LEAST_SQUARES):
        plain = evaluate(sparse_swarm, stochastic_sensor(), "shortest-length")
        fitted = refine(plain, estimator)
        assert fitted.summary.fit.consistency.nees.count == 0
