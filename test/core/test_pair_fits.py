"""The engine's fits of every pair: the whole swarm's, and each source's own."""

import time

import numpy as np

from swazure_ros.core.fit_measurements import fit_pairs, select_rows
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import ordered_blind_pairs
from swazure_ros.core.pair_fits import WholeFits, fit_pairs_estimates, local_estimates
from swazure_ros.core.sensor import Sensor
from swazure_ros.core.swarm_fit import swarm_solve

from .fits import stochastic_sensor, torus_swarm


def test_the_whole_swarm_s_fit_of_exact_readings_gives_every_joined_pair_its_truth():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    source, target = ordered_blind_pairs(hood.pairs)
    sweet = np.ones(len(source), dtype=bool)
    fit = fit_pairs_estimates(hood, source, target, sweet)
    joined = np.isfinite(fit.estimate).all(axis=1)
    points = hood.swarm.points
    assert joined.mean() > 0.9
    np.testing.assert_allclose(
        fit.estimate[joined], points[target[joined]] - points[source[joined]], atol=1e-7
    )
    # A deterministic sensor's sweet pairs take the sweet hops alone, both directions each.
    sweet_only = fit_pairs(hood, links=False)
    assert fit.measurements == 2 * len(sweet_only) and fit.downweighted == 0


def test_a_stochastic_sensor_s_pairs_take_one_fit_of_every_measurement():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), stochastic_sensor())
    source, target = ordered_blind_pairs(hood.pairs)
    fit = fit_pairs_estimates(hood, source, target, np.ones(len(source), dtype=bool))
    assert fit.measurements == 2 * len(fit_pairs(hood)) and fit.iterations == ()
    assert fit.estimate.shape == (len(source), 3) and fit.covariance.shape == (len(source), 3, 3)


def test_each_source_s_own_fit_reports_its_window_and_its_time():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    source, target = ordered_blind_pairs(hood.pairs)
    fit, seconds, sizes = local_estimates(hood, source, target, np.ones(len(source), dtype=bool))
    sources = np.unique(source)
    assert len(seconds) == len(sizes) == len(sources)
    assert (seconds >= 0).all() and (sizes > 1).all() and sizes.max() < hood.swarm.size
    joined = np.isfinite(fit.estimate).all(axis=1)
    points = hood.swarm.points
    np.testing.assert_allclose(
        fit.estimate[joined], points[target[joined]] - points[source[joined]], atol=1e-7
    )


def test_a_fit_whose_rows_another_fit_took_is_that_fit_solved_once():
    # A deterministic sensor has two fits: the sweet hops alone, and with the decaying hops
    # that join the sweet fit's parts. On a torus none joins: both take the same rows.
    hood = neighbourhood(torus_swarm(0.5, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    fits = WholeFits(hood, swarm=True)
    assert set(fits.rows) == {0, 1} and np.array_equal(fits.rows[0], fits.rows[1])
    assert fits.solved[1] is fits.solved[0]
    # The swarm solves each layer; counted as it counts them.
    assert fits.measurements == 2 * int(fits.rows[0].sum())
    assert fits.iterations[0] == fits.iterations[1]
    # And it is the fit a solve of the second layer's rows gives, to the bit.
    alone = swarm_solve(
        hood.swarm.size, select_rows(fits.every, fits.rows[1]), ids=hood.swarm.cloud_index
    )
    assert np.array_equal(alone.positions, fits.solved[1].positions, equal_nan=True)
    assert np.array_equal(alone.samples, fits.solved[1].samples)


def test_a_fit_solved_when_its_first_pairs_ask_counts_each_second_once():
    hood = neighbourhood(torus_swarm(0.5, "torus:200"), Sensor(6.0, 8.0, 8.0, 30.0))
    source, target = ordered_blind_pairs(hood.pairs)
    began = time.perf_counter()
    fits = WholeFits(hood)
    assert not fits.solved  # a least-squares fit waits for its pairs
    fits.estimates(source, target, np.ones(len(source), dtype=bool))
    wall = time.perf_counter() - began
    assert fits.solved and 0.0 < fits.seconds <= wall
