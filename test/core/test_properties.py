"""Invariants of the evaluation on random swarms (hypothesis)."""

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.neighbours import neighbour_pairs
from swazure_ros.core.sensor import Sensor

SENSOR = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755), "published")


@st.composite
def swarms(draw):
    seed = draw(st.integers(0, 2**31 - 1))
    count = draw(st.integers(8, 40))
    extent = draw(st.floats(6.0, 20.0))
    beta = draw(st.sampled_from([0.1, 0.3, 0.5, 0.7]))
    points = np.random.default_rng(seed).uniform(0, extent, size=(count, 3))
    return make_swarm(points, beta=beta, seed=seed)


SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(swarms(), st.sampled_from(["fewest-hops", "shortest-length"]))
def test_accurate_estimates_equal_the_truth(swarm, policy):
    pairs = evaluate(swarm, SENSOR.error_free(), policy).pairs
    found = pairs.status != 2
    np.testing.assert_allclose(pairs.estimate[found], pairs.truth[found], atol=1e-9)


@SETTINGS
@given(swarms(), st.sampled_from(["fewest-hops", "shortest-length"]))
def test_status_is_symmetric_and_reversed_paths_give_opposite_estimates(swarm, policy):
    pairs = evaluate(swarm, SENSOR, policy).pairs
    index = {(s, t): m for m, (s, t) in enumerate(zip(pairs.source, pairs.target))}
    for (source, target), m in index.items():
        n = index[(target, source)]
        assert pairs.status[m] == pairs.status[n]
        assert pairs.reason[m] == pairs.reason[n]
        if pairs.path(m) == pairs.path(n)[::-1] and pairs.path(m):
            np.testing.assert_allclose(pairs.estimate[m], -pairs.estimate[n], atol=1e-9)


@SETTINGS
@given(swarms())
def test_no_negative_tracking_distance_after_collision_removal(swarm):
    assert (neighbour_pairs(swarm, SENSOR).tracking >= 0).all()


@SETTINGS
@given(swarms(), st.sampled_from(["fewest-hops", "shortest-length"]))
def test_paths_are_connected_and_of_the_right_kind(swarm, policy):
    evaluation = evaluate(swarm, SENSOR, policy)
    hood, pairs = evaluation.hood, evaluation.pairs
    for m in range(len(pairs)):
        path = pairs.path(m)
        if not path:
            continue
        assert path[0] == pairs.source[m] and path[-1] == pairs.target[m]
        hops = hood.pairs.index(np.array(path[:-1]), np.array(path[1:]))
        assert (hops >= 0).all()
        assert hood.visible[hops].all()
        kinds = hood.pairs.range_class[hops]
        assert (kinds == 2).all() if pairs.status[m] == 0 else (kinds == 3).any()
