"""A swarm's neighbourhood: pairs, line of sight and graphs, whole, moved or without some FLSs."""

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.core.evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
)
from swazure_ros.core.neighbourhood import moved_neighbourhood, neighbourhood, without
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
