"""A heuristic made by the swarm, as the MoveRun machine drives it, against the engine."""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.clouds import Cloud
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, SWEET_PATH
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.observe import Measurement
from swazure_ros.core.sensor import DECAYING, SWEET
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.protocol.loops import discover
from swazure_ros.protocol.moves import (
    ARRIVED,
    FAILED,
    PROBE,
    RETURN,
    STEP_ASIDE,
    WALKING,
    Move,
    MoveRun,
    Walk,
    hops_here,
    next_hop,
    step_walk,
    walk_estimate,
)
from swazure_ros.sim.world import WorldSpec, make_world

from ..conftest import source_body_scene


def camera(ids, range_class, vectors):
    return Measurement(
        np.array(ids), np.array(range_class, dtype=np.int8), np.array(vectors, float), np.zeros(3)
    )


def test_a_walk_sums_each_fls_s_measured_hop_and_turns_back_at_the_target():
    walk = Walk(3, 5, (0, 4, 2))
    walk = step_walk(walk, camera([4, 9], [SWEET, SWEET], [[1.0, 0, 0], [0, 9, 0]]))
    assert (walk.at, walk.state) == (4, WALKING)
    walk = step_walk(walk, camera([2], [SWEET], [[0, 2.0, 0]]))
    assert walk.at == 2
    walk = step_walk(walk, camera([], [], np.zeros((0, 3))))
    assert (walk.state, walk.at) == (ARRIVED, 0)
    found = walk_estimate(walk)
    assert (found.status, found.path, found.vector.tolist()) == (SWEET_PATH, (0, 4, 2), [1, 2, 0])


def test_the_target_turns_a_walk_back_without_measuring_and_no_one_else_may():
    at_target = Walk(3, 5, (0, 4, 2), hop=2)
    assert next_hop(at_target) == ()
    back = step_walk(at_target, None)
    assert (back.state, back.at) == (ARRIVED, 0)
    with pytest.raises(ValueError, match="FLS 4 must measure its next hop, 2"):
        step_walk(Walk(3, 5, (0, 4, 2), hop=1), None)


def test_a_walk_fails_where_the_next_hop_is_not_a_sweet_measurement():
    walk = step_walk(Walk(3, 5, (0, 4, 2)), camera([4], [DECAYING], [[1.0, 0, 0]]))
    assert (walk.state, walk.at) == (FAILED, 0)
    assert walk_estimate(walk).status == NO_PATH


def make_moves(world, plain, technique, source_body=False):
    """Drive a MoveRun over ``world``: moves make revisions, walks go FLS to FLS."""
    run = MoveRun(1, plain, technique, 10, world.revision, 10.0, source_body)
    kinds: Counter[int] = Counter()
    pending = deque(run.start(0.0))
    group: dict[int, np.ndarray] = {}
    while not run.done:
        assert pending, "the run waits for nothing it asked for"
        action = pending.popleft()
        if isinstance(action, Move):
            kinds[action.kind] += 1
            home = world.home.points[world.index(action.fls_id)]
            group[action.fls_id] = home if action.kind == RETURN else home + action.displacement
            if len(group) == action.group_size:
                world = world.moved(group, revision=action.group)
                group = {}
                pending.extend(run.on_revision(world.revision, 0.0))
        else:
            walk = action
            while walk.state == WALKING:
                walk = step_walk(walk, world.measurement(walk.at, next_hop(walk)))
            pending.extend(run.on_estimates(walk.source_id, [walk_estimate(walk)], 0.0))
    return run.outcome, world, kinds


@pytest.mark.parametrize(
    ("technique", "kind"), [("move-obstructing", STEP_ASIDE), ("move-source", PROBE)]
)
def test_the_moves_made_by_the_machine_equal_the_engine(technique, kind):
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    policy = "shortest-length"
    found = discover(world.seen, world.ids, world.sensor, world.swarm.radius, policy)
    plain = evaluation_of(world.hood, policy, found.estimates)
    outcome, after, kinds = make_moves(world, plain, technique)
    engine, plan = run_technique(evaluate(world.swarm, world.sensor, policy), technique, 10)
    assert plan.resolved.sum() > 500 and outcome.walks == plan.resolved.sum()
    # Every FLS sent aside (or to a probe) comes back, and only those moves are made.
    assert set(kinds) == {kind, RETURN} and kinds[kind] == kinds[RETURN]
    assert outcome.moved == kinds.total()
    if technique == "move-source":
        assert kinds[PROBE] == outcome.walks  # one probe, then one walk, per resolved pair
    np.testing.assert_array_equal(outcome.heuristic.resolved, plan.resolved)
    np.testing.assert_array_equal(outcome.evaluation.pairs.status, engine.pairs.status)
    np.testing.assert_array_equal(outcome.evaluation.pairs.nodes, engine.pairs.nodes)
    np.testing.assert_allclose(outcome.evaluation.pairs.estimate, engine.pairs.estimate, atol=1e-9)
    # Every FLS is back at its point.
    np.testing.assert_array_equal(after.swarm.points, world.swarm.points)


def test_a_lost_walk_costs_its_pair_and_the_run_goes_on_after_the_deadline():
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    found = discover(world.seen, world.ids, world.sensor, world.swarm.radius, "shortest-length")
    plain = evaluation_of(world.hood, "shortest-length", found.estimates)
    run = MoveRun(1, plain, "move-obstructing", 10, 0, timeout=5.0)
    moves = run.start(0.0)
    walks = run.on_revision(moves[0].group, 1.0)
    assert walks and all(isinstance(walk, Walk) for walk in walks)
    # Every walk but the first comes back; the first is lost.
    for walk in walks[1:]:
        done = walk_estimate(Walk(walk.run_id, walk.revision, walk.path, state=ARRIVED))
        assert run.on_estimates(walk.source_id, [done], 2.0) == []
    assert run.on_tick(6.0) == []
    returns = run.on_tick(7.1)
    assert returns and all(move.kind == RETURN for move in returns)
    assert "no result of the path walks" in run.warnings[0]
    assert run.timeouts == 1


@pytest.mark.parametrize("source_body", [False, True], ids=["spec-rule", "source-body"])
def test_the_source_s_body_at_its_probe_fails_the_walk_unless_the_plan_checked_it(
    sensor, source_body
):
    world = make_world(Cloud("scene", source_body_scene(), 1.0, "array"), sensor, radius=0.5)
    policy = "shortest-length"
    found = discover(world.seen, world.ids, world.sensor, world.swarm.radius, policy)
    plain = evaluation_of(world.hood, policy, found.estimates)
    outcome, _, _ = make_moves(world, plain, "move-source", source_body)
    engine, plan = run_technique(
        evaluate(world.swarm, world.sensor, policy), "move-source", 10, source_body=source_body
    )
    pairs = engine.pairs
    m = int(np.flatnonzero((pairs.source == 0) & (pairs.target == 2))[0])
    assert plan.resolved[m] and outcome.walks == plan.resolved.sum()
    differ = np.flatnonzero(outcome.evaluation.pairs.status != pairs.status).tolist()
    # The spec's plan has the source stand between the helper and the target: the
    # helper's walk fails there. Planned with the body checked, the swarm is the engine.
    assert differ == ([] if source_body else [m])
    assert outcome.heuristic.resolved[m] == source_body
    if source_body:
        np.testing.assert_array_equal(outcome.evaluation.pairs.nodes, pairs.nodes)
        np.testing.assert_allclose(outcome.evaluation.pairs.estimate, pairs.estimate, atol=1e-9)


def test_a_walk_s_hops_here_are_those_out_to_the_first_fls_elsewhere_or_its_target():
    walk = Walk(run_id=1, revision=0, path=(1, 2, 3, 4, 5), hop=1)
    # FLSs 2 and 3 here measure 3 and 4; 4 is elsewhere, so the walk leaves with it.
    assert hops_here(walk, {1, 2, 3, 5}) == ([2, 3], [3, 4])
    # All here: every hop out to the target, which measures none.
    assert hops_here(walk, {1, 2, 3, 4, 5}) == ([2, 3, 4], [3, 4, 5])
    assert hops_here(walk, {1, 3, 4, 5}) == ([], [])  # its FLS is elsewhere
    assert hops_here(replace(walk, state=ARRIVED, hop=0), {1, 2, 3, 4, 5}) == ([], [])
