"""The swarm's own fit: the central fit's positions from neighbour messages, honest covariances."""

import numpy as np

from swazure_ros.core import swarm_fit as swarm_fit_module
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, SWEET_PATH
from swazure_ros.core.fit import LEAST_SQUARES, SWARM_FIT, refine
from swazure_ros.core.fit_measurements import fit_pairs, measurements, with_outliers
from swazure_ros.core.least_squares import solve
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import ordered_blind_pairs
from swazure_ros.core.swarm_fit import swarm_solve

from .fits import exact, stochastic_sensor, torus_swarm


def test_a_consistent_triangle_is_solved_to_the_central_fit_s_positions():
    points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])
    first, second = [0, 1, 2, 1, 0, 2], [1, 2, 0, 0, 2, 1]
    measured = exact(first, second, points[second] - points[first])
    swarm = swarm_solve(3, measured)
    np.testing.assert_allclose(swarm.positions, points, atol=1e-9)
    np.testing.assert_allclose(swarm.positions, solve(3, measured).positions, atol=1e-9)


def test_two_measurements_of_one_vector_average_and_their_samples_give_the_variance():
    measured = exact([0, 1], [1, 0], [[7.0, 0, 0], [-7.2, 0, 0]], variance=0.5)
    swarm = swarm_solve(2, measured, samples=4000)
    estimate, covariance = swarm.relative(np.array([0]), np.array([1]))
    np.testing.assert_allclose(estimate, [[7.1, 0, 0]], atol=1e-9)
    # The central fit's covariance is 0.25 I; 4,000 draws find it to a few per cent.
    np.testing.assert_allclose(covariance[0], np.eye(3) * 0.25, atol=0.02)


def test_each_connected_part_has_the_central_fit_s_gauge_and_no_estimate_crosses_parts():
    # Parts {0, 1} and {2, 3}; FLS 4 is in no measurement.
    measured = exact([0, 1, 2, 3], [1, 0, 3, 2], [[7.0, 0, 0], [-7, 0, 0], [0, 7, 0], [0, -7, 0]])
    swarm = swarm_solve(5, measured)
    assert swarm.part.tolist() == [0, 0, 1, 1, -1]
    np.testing.assert_allclose(swarm.positions[:4], solve(5, measured).positions[:4], atol=1e-9)
    assert np.isnan(swarm.positions[4]).all()
    estimate, covariance = swarm.relative(np.array([0, 0, 2]), np.array([1, 2, 3]))
    np.testing.assert_allclose(estimate[[0, 2]], [[7, 0, 0], [0, 7, 0]], atol=1e-9)
    assert np.isnan(estimate[1]).all() and np.isnan(covariance[1]).all()


def test_the_swarm_s_fit_of_a_torus_is_the_central_fit_s_and_its_covariance_is_honest():
    swarm = torus_swarm(0.3, "torus:200")
    plain = evaluate(swarm, stochastic_sensor(mean_error=0.03), "shortest-length")
    central, swarm_fit = refine(plain, LEAST_SQUARES), refine(plain, SWARM_FIT)
    has_path = plain.pairs.status != NO_PATH
    assert has_path.sum() > 1000
    np.testing.assert_allclose(
        swarm_fit.pairs.estimate[has_path], central.pairs.estimate[has_path], atol=1e-6
    )
    assert swarm_fit.summary.fit.estimator == SWARM_FIT
    facts = swarm_fit.summary.fit
    assert facts.downweighted == central.summary.fit.downweighted
    # One fit under a stochastic sensor: its solves, then the covariance's.
    assert len(facts.iterations) == 1 and len(facts.iterations[0]) >= 2
    assert min(facts.iterations[0]) >= 1
    # Its covariance is sampled, not inverted: each pair's within sampling error of the
    # central one, and a NEES as honest.
    trace = np.trace(swarm_fit.pairs.covariance[has_path], axis1=1, axis2=2)
    central_trace = np.trace(central.pairs.covariance[has_path], axis1=1, axis2=2)
    assert 0.85 <= np.median(trace / central_trace) <= 1.15
    assert 2.5 <= facts.consistency.nees.mean <= 3.7
    sweet = plain.pairs.status == SWEET_PATH
    assert (
        swarm_fit.pairs.distance_error[sweet].mean()
        < 0.5 * plain.pairs.distance_error[sweet].mean()
    )


def test_the_swarm_s_robust_fit_rejects_what_the_central_one_rejects():
    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    flipped = with_outliers(measurements(hood, fit_pairs(hood)), 0.10, 20.0, seed=1)
    size = hood.swarm.size
    central, swarm = solve(size, flipped), swarm_solve(size, flipped, samples=0)
    assert swarm.downweighted == central.downweighted > 0
    source, target = ordered_blind_pairs(hood.pairs)
    estimate, _ = swarm.relative(source, target)
    central_estimate, _ = central.relative(source, target)
    np.testing.assert_allclose(estimate, central_estimate, atol=1e-6)


def test_a_warm_start_from_the_last_fit_settles_in_fewer_iterations():
    hood = neighbourhood(torus_swarm(0.3, "torus:200"), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    size = hood.swarm.size
    cold = swarm_solve(size, measured, robust=False, samples=0)
    warm = swarm_solve(size, measured, robust=False, samples=0, start=cold.positions)
    assert warm.iterations[0] < cold.iterations[0] // 2
    np.testing.assert_allclose(warm.positions, cold.positions, atol=1e-6)


def test_noise_drawn_and_its_flows_formed_a_few_rows_at_a_time_are_the_same_bits(monkeypatch):
    from swazure_ros.core import swarm_edges, swarm_fit
    from swazure_ros.core.swarm_edges import edges_of, weighted

    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    size, ids = hood.swarm.size, np.arange(hood.swarm.size)
    weights = np.linspace(0.5, 1.0, len(measured.first))
    edges = weighted(edges_of(size, measured), measured, weights)
    whole = swarm_fit.noise_flows(edges, measured, weights, 8, ids)
    assert len(measured.first) > 40 and len(edges.rows) > 40  # more than one chunk of 7
    for module in (swarm_edges, swarm_fit):
        monkeypatch.setattr(module, "FLOW_CHUNK", 7)
    chunked = swarm_fit.noise_flows(edges, measured, weights, 8, ids)
    assert chunked.tobytes() == whole.tobytes()
    assert np.abs(whole).max() > 0  # flows of real draws, not of nothing


def test_each_fls_s_noise_flows_summed_a_few_flss_at_a_time_are_the_whole_flows_sums(
    monkeypatch,
):
    from swazure_ros.core import swarm_edges, swarm_fit
    from swazure_ros.core.swarm_edges import edges_of, sums_into, weighted

    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    size, ids = hood.swarm.size, np.arange(hood.swarm.size)
    weights = np.linspace(0.5, 1.0, len(measured.first))
    edges = weighted(edges_of(size, measured), measured, weights)
    expected = sums_into(swarm_fit.noise_flows(edges, measured, weights, 8, ids), edges.starts)
    assert swarm_fit.noise_sides(edges, measured, weights, 8, ids).tobytes() == expected.tobytes()
    for module in (swarm_edges, swarm_fit):
        monkeypatch.setattr(module, "FLOW_CHUNK", 7)  # FLSs of more edges than a chunk too
    assert np.diff(edges.starts).max() > 7 and size > 20
    chunked = swarm_fit.noise_sides(edges, measured, weights, 8, ids)
    assert chunked.tobytes() == expected.tobytes()
    assert np.abs(expected).max() > 0


def test_the_engine_s_solve_in_place_is_the_same_bits_as_an_fls_s_steps():
    from swazure_ros.core.conjugate_gradients import solved, system_of
    from swazure_ros.core.swarm_edges import edges_of

    from .interpreting import interpreted

    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    size = hood.swarm.size
    edges = edges_of(size, measured)
    flows = swarm_fit_module.noise_flows(edges, measured, np.ones(len(measured.first)), 4,
                                         np.arange(size))  # fmt: skip
    system = system_of(edges, flows)
    start = np.linspace(-1.0, 1.0, size * 3 * 4).reshape(size, 3, 4)
    kept = start.copy()
    in_place, iterations = solved(system, start)
    assert start.tobytes() == kept.tobytes()  # the caller's start is not overwritten
    stepped, stepped_iterations = interpreted(solved, system, start)
    assert iterations == stepped_iterations > 10
    assert in_place.tobytes() == stepped.tobytes()


def test_the_pairs_covariances_read_a_few_at_a_time_are_the_same_bits(monkeypatch):
    hood = neighbourhood(torus_swarm(0.3), stochastic_sensor())
    measured = measurements(hood, fit_pairs(hood))
    fit = swarm_solve(hood.swarm.size, measured, samples=8)
    source, target = ordered_blind_pairs(hood.pairs)
    assert len(source) > 40  # more than one chunk of 7
    whole = fit.relative(source, target)
    monkeypatch.setattr(swarm_fit_module, "FLOW_CHUNK", 7)
    chunked = fit.relative(source, target)
    for one, other in zip(whole, chunked, strict=True):
        assert one.tobytes() == other.tobytes()
    trace = np.trace(whole[1], axis1=1, axis2=2)
    assert (trace[np.isfinite(trace)] > 0).sum() > 40  # sampled covariances, not nothing
