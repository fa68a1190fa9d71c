"""Statuses, paths, estimates and summary on the hand-built scene of conftest.py."""

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
)
from swazure_ros.core.hop_errors import measured_vectors

from ..conftest import A, B, C, D, K, scene


def result(evaluation, source, target):
    pairs = evaluation.pairs
    index = int(np.flatnonzero((pairs.source == source) & (pairs.target == target))[0])
    return pairs, index


@pytest.mark.parametrize("policy", ["fewest-hops", "shortest-length"])
def test_sweet_path_through_a_common_sweet_neighbour(sensor, policy):
    swarm = scene(A, B, C)
    evaluation = evaluate(swarm, sensor, policy)
    pairs, m = result(evaluation, A, C)
    assert len(pairs) == 2  # (A, C) and (C, A)
    assert (pairs.status[m], pairs.reason[m]) == (SWEET_PATH, REASON_NONE)
    assert pairs.path(m) == [A, B, C]
    assert (pairs.hops[m], pairs.sweet_hops[m], pairs.decaying_hops[m]) == (2, 2, 0)
    hops = measured_vectors(sensor, swarm.points, 0.5, [A, B], [B, C])
    np.testing.assert_array_equal(pairs.estimate[m], hops[0] + hops[1])
    np.testing.assert_array_equal(pairs.truth[m], [4.0, 0.0, 0.0])
    assert pairs.sweet_obstructed[m] == False  # noqa: E712


def test_accurate_sensor_estimates_the_truth(sensor):
    evaluation = evaluate(scene(A, B, C), sensor.error_free(), "shortest-length")
    pairs, m = result(evaluation, A, C)
    np.testing.assert_allclose(pairs.estimate[m], [4.0, 0.0, 0.0], atol=1e-12)
    assert pairs.distance_error[m] == pytest.approx(0.0, abs=1e-10)


def test_blocked_pair_falls_back_to_a_decaying_path(sensor):
    evaluation = evaluate(scene(A, B, C, K, D), sensor, "fewest-hops")
    pairs, m = result(evaluation, A, C)
    assert (pairs.status[m], pairs.reason[m]) == (DECAYING_PATH, REASON_BLOCKED)
    assert pairs.path(m) == [A, D, C]
    assert (pairs.sweet_hops[m], pairs.decaying_hops[m]) == (0, 2)
    # The sweet path A-B-C exists without line of sight: its hop A-B is blocked by K alone.
    assert pairs.sweet_connected[m] and pairs.sweet_obstructed[m]
    assert pairs.obstructing_flss[m] == 1
    reverse, n = result(evaluation, C, A)
    assert reverse.path(n) == [C, D, A]


def test_fls_without_sweet_neighbours_has_no_sweet_path(sensor):
    evaluation = evaluate(scene(A, B, C, K, D), sensor, "shortest-length")
    pairs, m = result(evaluation, A, K)
    assert (pairs.status[m], pairs.reason[m]) == (DECAYING_PATH, REASON_NO_SWEET_PATH)
    assert pairs.path(m) == [A, D, K]
    assert not pairs.sweet_connected[m]


def test_no_path_when_nothing_is_in_sight(sensor):
    evaluation = evaluate(scene(A, B, C, K), sensor, "shortest-length")
    pairs, m = result(evaluation, A, C)
    assert (pairs.status[m], pairs.reason[m]) == (NO_PATH, REASON_BLOCKED)
    assert pairs.path(m) == []
    assert np.isnan(pairs.estimate[m]).all()
    _, k = result(evaluation, A, K)
    assert (pairs.status[k], pairs.reason[k]) == (NO_PATH, REASON_NO_SWEET_PATH)
