"""The least-squares fit: exact on exact data, honest covariances, the gauge, robustness."""

from functools import partial

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, SWEET_PATH
from swazure_ros.core.fit import (
    CHI2_95_3DOF,
    LEAST_SQUARES,
    LOCAL_LEAST_SQUARES,
    Measurements,
    fit_pairs,
    heard_in_window,
    measurements,
    normalized_errors,
    path_estimates,
    refine,
    solve,
    with_outliers,
)
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import ordered_blind_pairs
from swazure_ros.core.observe import observations
from swazure_ros.core.sensor import BLIND, DECAYING, SWEET, Sensor, SensorNoise
from swazure_ros.files.cloud_files import load_cloud


def stochastic_sensor(mean_error=0.0, sd=0.01, direction_deg=0.2):
    """The published ranges with a seeded scatter and a known bias."""
    noise = SensorNoise(
        tracking_cm=(0.0, 30.0),
        mean_error=(mean_error, mean_error),
        detection=(1.0, 1.0),
        distance_sd=(sd, sd),
        direction_sd_deg=(direction_deg, direction_deg),
        seed=3,
    )
    return Sensor(6.0, 8.0, 8.0, 30.0, name="scatter", noise=noise)


def exact(first, second, vectors, variance=1.0):
    """Measurements (M,) of the vectors (M, 3) with an isotropic variance, cm^2."""
    count = len(first)
    eye = np.broadcast_to(np.eye(3), (count, 3, 3))
    return Measurements(
        np.asarray(first),
        np.asarray(second),
        np.asarray(vectors, dtype=float),
        eye * variance,
        eye / variance,
    )


def torus_swarm(beta=0.3, shape="torus:120"):
    """At beta 0.3: torus:120's blind pairs have a sweet path or none, a helix's a decaying one."""
    return make_swarm(load_cloud(shape).points * 1.6, beta=beta)


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


def test_the_fit_uses_the_sweet_hops_and_only_the_decaying_hops_that_join_parts():
    hood = neighbourhood(torus_swarm(0.3, "helix"), Sensor(6.0, 8.0, 8.0, 30.0))
    pairs = hood.pairs
    sweet_only, joined = fit_pairs(hood, links=False), fit_pairs(hood)
    assert (pairs.range_class[sweet_only] == SWEET).all() and hood.visible[joined].all()
    links = np.setdiff1d(joined, sweet_only)
    part = hood.sweet_visible.components()
    assert len(links) > 0
    assert (part[pairs.first[links]] != part[pairs.second[links]]).all()


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


def test_with_outliers_repeats_and_turns_by_the_angle_asked():
    measured = exact([0, 1, 2] * 30, [1, 2, 0] * 30, np.tile([[7.0, 0, 0]], (90, 1)))
    turn = partial(with_outliers, measured, 0.5, 30.0, seed=2)
    first, second = turn(), turn()
    np.testing.assert_array_equal(first.vectors, second.vectors)
    moved = (first.vectors != measured.vectors).any(axis=1)
    cosine = (first.vectors[moved] @ [1.0, 0, 0]) / 7.0
    np.testing.assert_allclose(cosine, np.cos(np.radians(30.0)))


def test_a_source_hears_its_radio_neighbours_readings_of_each_other():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    seen = observations(hood)
    ids = np.arange(hood.swarm.size) + 1000  # FLS ids, not swarm indices
    pairs = hood.pairs
    for source in (0, 57, 199):
        mine = (pairs.first == source) | (pairs.second == source)
        radio = mine & np.isin(pairs.range_class, [BLIND, SWEET])
        others = np.where(pairs.first[radio] == source, pairs.second[radio], pairs.first[radio])
        window, heard = heard_in_window(seen, ids, source)
        assert window.tolist() == [1000 + source, *(1000 + np.sort(others)).tolist()]
        # Every reading is between window FLSs, a visible sweet or decaying pair, in both
        # directions where both FLSs are in the window.
        assert np.isin(heard.owner, window).all() and np.isin(heard.other, window).all()
        index = hood.pairs.index(heard.owner - 1000, heard.other - 1000)
        assert (index >= 0).all() and hood.visible[index].all()
        np.testing.assert_array_equal(heard.tracking, pairs.tracking[index])
        inside = np.isin(pairs.first, window - 1000) & np.isin(pairs.second, window - 1000)
        measured = inside & hood.visible & np.isin(pairs.range_class, [SWEET, DECAYING])
        assert len(heard.owner) == 2 * measured.sum()


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
