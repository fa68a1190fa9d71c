"""The distributed path search, run round by round in memory, against the core engine."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.discovery import (
    ANY_VISIBLE,
    PHASES,
    SWEET_ALL,
    SWEET_VISIBLE,
    Found,
    PathSearch,
    bucket_width,
    estimate,
    local_view,
    phase_targets,
)
from swazure_ros.core.evaluate import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    SWEET_PATH,
    evaluate_pairs,
    neighbourhood,
)
from swazure_ros.core.observe import observations
from swazure_ros.core.paths import POLICIES
from swazure_ros.sim.world import WorldSpec

from ..conftest import A, B, C, D, K, scene


def discover(hood, policy):
    """Every phase for every FLS, with a perfect radio: (source, phase) -> {target: Found}."""
    seen = observations(hood)
    ids = hood.swarm.cloud_index
    views = {int(ids[i]): local_view(seen, ids, i) for i in range(len(ids))}
    width = bucket_width(hood.sensor.sweet_min, policy)
    results: dict[tuple[int, int], dict[int, Found]] = {}
    for phase in PHASES:
        searches = {}
        for fls, view in views.items():
            targets = phase_targets(phase, view.blind, results.get((fls, SWEET_VISIBLE), {}))
            searches[fls] = PathSearch(
                view, phase, policy, width, int(ids.max()) + 1, targets if len(targets) else None
            )
        round_ = 0
        while True:
            offers = {fls: search.offer(round_) for fls, search in searches.items()}
            for fls, offer in offers.items():
                for other in views[fls].other.tolist():
                    searches[other].hear(fls, offer)
            done = np.array([fls for fls, offer in offers.items() if offer.finished], dtype=int)
            for search in searches.values():
                search.close(done)
            if not any(offer.pending or len(offer) for offer in offers.values()):
                break
            round_ += 1
        results.update({(fls, phase): search.results for fls, search in searches.items()})
    return results


def test_bucket_width_is_one_hop_or_just_under_the_shortest_hop():
    assert bucket_width(6.0, "fewest-hops") == 1.0
    assert 6.0 - 1e-6 < bucket_width(6.0, "shortest-length") < 6.0
    with pytest.raises(ValueError, match="sweet_min"):
        bucket_width(0.0, "shortest-length")


def test_scene_pairs_get_the_status_of_section_5(sensor):
    # A-C is blind; A-B-C is sweet but K blocks A-B; D is decaying to A and C.
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    results = discover(hood, "shortest-length")
    found = estimate(
        2, *(results[(0, phase)].get(2) for phase in (SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE))
    )
    assert (found.status, found.reason) == (DECAYING_PATH, REASON_BLOCKED)
    assert found.path == (0, 4, 2) and found.radio_path == (0, 1, 2)


def test_estimate_orders_the_phases():
    hop = Found((0, 1, 2), 13.0, np.ones(3))
    assert estimate(2, hop, hop, None).status == SWEET_PATH
    assert estimate(2, None, hop, hop).reason == REASON_BLOCKED
    blocked = estimate(2, None, hop, None)
    assert (blocked.status, blocked.reason, blocked.hops) == (NO_PATH, REASON_BLOCKED, 0)
    assert estimate(2, None, None, None).reason == REASON_NO_SWEET_PATH


@pytest.mark.parametrize("policy", POLICIES)
@pytest.mark.parametrize("beta", [0.3, 0.5])
def test_every_pair_matches_the_engine(policy, beta):
    # torus:120 at 1.6 x has sweet, blocked and unreachable pairs at both betas.
    world = WorldSpec("torus:120", scale=1.6, beta=beta).build()
    hood = world.hood
    results = discover(hood, policy)
    engine = evaluate_pairs(hood, policy)
    ids = world.ids
    assert len(engine) > 10_000 and (engine.reason == REASON_BLOCKED).sum() > 1000
    for pair in range(len(engine)):
        source, target = int(ids[engine.source[pair]]), int(ids[engine.target[pair]])
        found = estimate(target, *(results[(source, phase)].get(target) for phase in PHASES))
        assert (found.status, found.reason) == (engine.status[pair], engine.reason[pair])
        assert found.path == tuple(int(ids[k]) for k in engine.path(pair))
        if found.status != NO_PATH:
            np.testing.assert_allclose(found.vector, engine.estimate[pair], rtol=0, atol=1e-9)


@pytest.mark.parametrize("policy", POLICIES)
def test_evaluation_of_the_estimates_equals_the_engine(policy):
    from swazure_ros.core.evaluate import evaluate

    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    results = discover(world.hood, policy)
    ids = world.ids
    found = {}
    for fls in ids.tolist():
        view = local_view(world.seen, ids, int(np.searchsorted(ids, fls)))
        found[fls] = [
            estimate(t, *(results[(fls, phase)].get(t) for phase in PHASES))
            for t in view.blind.tolist()
        ]
    from swazure_ros.core.discovery import evaluation_of

    distributed = evaluation_of(world.hood, policy, found)
    engine = evaluate(world.swarm, world.sensor, policy)
    engine.summary.pop("seconds")
    assert distributed.summary == engine.summary
    np.testing.assert_array_equal(distributed.pairs.nodes, engine.pairs.nodes)
    np.testing.assert_allclose(distributed.pairs.estimate, engine.pairs.estimate, atol=1e-9)
