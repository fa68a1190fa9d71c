"""Statuses, paths, estimates and summary on the hand-built scene of conftest.py."""

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.evaluate import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
    evaluate,
    neighbourhood,
)
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.sensor import measured_vectors
from swazure_ros.files.cloud_files import load_cloud

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


def test_summary_counts_of_the_full_scene(sensor):
    summary = evaluate(scene(A, B, C, K, D), sensor, "fewest-hops").summary
    # Blind: A-C, A-K, B-K, C-K, both ways. Every one gets a decaying path via D.
    assert summary.pairs.blind_pairs == 8
    assert summary.pairs.decaying_pct == 100.0
    assert summary.pairs.blocked_pairs == 2
    assert summary.pairs.no_sweet_path_pairs == 6
    assert summary.pairs.obstructed_path_pct == 100.0  # the one S_all path, both ways
    assert summary.pairs.hops.mean == 2.0
    assert summary.kissing_pairs == 0
    for key in ("flss", "removed", "radius", "dmin", "seconds", "sweet_pct", "no_path_pct"):
        assert key in summary.as_document()


def test_summary_gives_the_distance_error_of_each_class_of_pair_apart(sensor):
    # The hand-built scene: every blind pair's path is decaying, none is sweet.
    summary = evaluate(scene(A, B, C, K, D), sensor, "fewest-hops").summary
    assert summary.pairs.distance_error_pct_sweet_paths.count == 0
    decaying = summary.pairs.distance_error_pct_decaying_paths
    assert decaying.count == 8 and decaying.mean == summary.pairs.distance_error_pct.mean
    # A torus whose pairs are both: each class's mean is over its own pairs alone.
    evaluation = evaluate(
        make_swarm(load_cloud("torus:120", 6.0).points, beta=0.5), sensor, "shortest-length"
    )
    pairs, summary = evaluation.pairs, evaluation.summary
    for status, key in ((SWEET_PATH, "sweet"), (DECAYING_PATH, "decaying")):
        errors = pairs.distance_error[pairs.status == status]
        assert len(errors) > 100
        stats = getattr(summary.pairs, f"distance_error_pct_{key}_paths")
        assert stats.mean == pytest.approx(errors.mean())
    sweet = summary.pairs.distance_error_pct_sweet_paths.mean
    assert sweet < summary.pairs.distance_error_pct.mean


def test_without_a_stopped_fls_paths_avoid_it_and_its_body_still_blocks(sensor):
    from swazure_ros.core.evaluate import evaluate_pairs, neighbourhood, without

    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    # K stops: A-B stays blocked by its body, so A-C keeps its decaying path via D.
    pairs = evaluate_pairs(without(hood, np.array([K])), "fewest-hops")
    m = int(np.flatnonzero((pairs.source == A) & (pairs.target == C))[0])
    assert (pairs.status[m], pairs.reason[m], pairs.path(m)) == (
        DECAYING_PATH,
        REASON_BLOCKED,
        [A, D, C],
    )
    # D stops: no path is left, and the sweet path through B is still blocked.
    pairs = evaluate_pairs(without(hood, np.array([D])), "fewest-hops")
    assert (pairs.status[m], pairs.reason[m]) == (NO_PATH, REASON_BLOCKED)
    # B stops: no sweet path exists any more, blocked or not.
    pairs = evaluate_pairs(without(hood, np.array([B])), "fewest-hops")
    assert (pairs.status[m], pairs.reason[m], pairs.path(m)) == (
        DECAYING_PATH,
        REASON_NO_SWEET_PATH,
        [A, D, C],
    )


@pytest.mark.parametrize("shape", ["torus:120", "helix:100", "sphere:200"])
def test_a_moved_neighbourhood_equals_the_one_computed_from_scratch(shape):
    from swazure_ros.core.evaluate import moved_neighbourhood
    from swazure_ros.sim.world import WorldSpec

    world = WorldSpec(shape, scale=1.6, beta=0.5).build()
    rng = np.random.default_rng(7)
    swarm, hood = world.swarm, world.hood
    changed = 0
    for _ in range(20):
        moved = rng.choice(swarm.size, size=int(rng.integers(1, 6)), replace=False)
        points = swarm.points.copy()
        points[moved] += rng.normal(scale=swarm.radius, size=(len(moved), 3))
        new = replace(swarm, points=points)
        quick = moved_neighbourhood(hood, new, moved)
        full = neighbourhood(new, world.sensor)
        for name in ("first", "second", "distance", "tracking", "range_class"):
            np.testing.assert_array_equal(getattr(quick.pairs, name), getattr(full.pairs, name))
        np.testing.assert_array_equal(quick.visible, full.visible)
        changed += int((full.visible[: len(hood.visible)] != hood.visible).any())
        swarm, hood = new, quick  # moves pile up, as a heuristic's revisions do
    assert changed > 5  # the moves did change lines of sight
