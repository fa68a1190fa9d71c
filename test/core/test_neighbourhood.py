"""A swarm's neighbourhood: pairs, line of sight and graphs, whole, moved or without some FLSs."""

from dataclasses import FrozenInstanceError, replace

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.core.evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
)
from swazure_ros.core.neighbourhood import (
    NeighbourGraphs,
    moved_neighbourhood,
    neighbourhood,
    neighbourhood_of,
    without,
)
from swazure_ros.sim.world import WorldSpec

from ..conftest import A, B, C, D, K, scene


def test_without_a_stopped_fls_paths_avoid_it_and_its_body_still_blocks(sensor):
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


def test_each_graph_is_built_when_first_asked_for_and_then_kept(sensor):
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    assert hood.graphs == NeighbourGraphs()  # nothing built by the neighbourhood itself
    sweet = hood.sweet_visible
    assert hood.graphs.sweet_visible is sweet
    assert (hood.graphs.sweet_all, hood.graphs.any_visible) == (None, None)
    assert hood.sweet_visible is sweet  # not built again
    evaluate_pairs(hood, "fewest-hops")
    built = (hood.graphs.sweet_all, hood.graphs.any_visible, hood.graphs.sweet_components)
    assert all(graph is not None for graph in built)
    assert (hood.sweet_all, hood.any_visible, hood.sweet_components) == built


def test_forgotten_graphs_are_let_go_and_built_again_the_same_when_asked_for(sensor):
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    evaluate_pairs(hood, "fewest-hops")
    before = hood.any_visible
    hood.forget_graphs()
    assert hood.graphs == NeighbourGraphs()
    again = hood.any_visible
    assert again is not before
    for name in ("indptr", "indices", "weights", "labels"):
        np.testing.assert_array_equal(getattr(again, name), getattr(before, name))
    np.testing.assert_array_equal(again.edge_costs(), before.edge_costs())


def test_a_world_that_only_senses_builds_no_graph(sensor):
    from swazure_ros.core.observe import observations

    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    observations(hood)
    assert hood.graphs == NeighbourGraphs()


def test_a_neighbourhood_made_from_another_builds_its_own_graphs(sensor):
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    whole = hood.any_visible
    assert replace(hood, kept_counts=hood.counts).graphs == NeighbourGraphs()
    gone = without(hood, np.array([D]))
    assert gone.graphs == NeighbourGraphs()
    degree = np.diff(whole.indptr)[D]
    assert degree > 0 and np.diff(gone.any_visible.indptr)[D] == 0  # D's pairs left out
    assert gone.any_visible.edges == whole.edges - degree
    assert hood.any_visible is whole


def test_a_neighbourhood_s_data_are_frozen(sensor):
    hood = neighbourhood(scene(A, B, C), sensor)
    with pytest.raises(FrozenInstanceError):
        hood.visible = hood.visible  # type: ignore[misc]
    with pytest.raises(FrozenInstanceError):
        hood.graphs = NeighbourGraphs()  # type: ignore[misc]


def test_indices_that_are_no_fls_of_the_swarm_are_refused(sensor):
    swarm = scene(A, B, C)
    hood = neighbourhood(swarm, sensor)
    with pytest.raises(ValueError, match="`flss` must be swarm indices of FLSs, 0 to 2"):
        neighbourhood_of(swarm, sensor, [3])
    with pytest.raises(ValueError, match="`moved` must be swarm indices"):
        moved_neighbourhood(hood, swarm, [-1])
    with pytest.raises(ValueError, match="`gone` must be swarm indices"):
        without(hood, [5])
    with pytest.raises(ValueError, match="must have the 3 FLSs of `hood`: 5"):
        moved_neighbourhood(hood, scene(A, B, C, K, D), [0])
