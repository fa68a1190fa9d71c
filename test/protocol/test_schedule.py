"""The swarm's move schedule: batches whose pairs walk their paths as if alone, and walks
that replace the engine's estimates."""

import numpy as np
import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import SWEET_PATH
from swazure_ros.core.heuristics.folding import apply
from swazure_ros.core.heuristics.obstructing import move_obstructing
from swazure_ros.core.heuristics.source import move_source
from swazure_ros.protocol.moves import ARRIVED, WALKING, Walk, step_walk
from swazure_ros.protocol.schedule import move_batches, walked
from swazure_ros.sim.world import WorldSpec


@pytest.mark.parametrize("beta", [0.3, 0.5])
@pytest.mark.parametrize("technique", ["move-obstructing", "move-source"])
def test_move_batches_let_every_pair_of_a_batch_walk_its_path_as_if_alone(beta, technique):
    world = WorldSpec("torus:120", scale=1.6, beta=beta).build()
    evaluation = evaluate(world.swarm, world.sensor, "shortest-length")
    if technique == "move-obstructing":
        heuristic = move_obstructing(evaluation)
    else:
        heuristic = move_source(evaluation, 10)
    batches = move_batches(evaluation, heuristic)
    assert sorted(np.concatenate(batches).tolist()) == np.flatnonzero(heuristic.resolved).tolist()
    assert len(batches) < heuristic.resolved.sum() / 5  # batching pays
    radius = world.swarm.radius
    vectors = {}
    for batch in batches:
        moved = {}
        for pair in batch.tolist():
            moved.update({int(world.ids[fls]): to for fls, _, to in heuristic.moves(pair)})
        # FLSs moved for different pairs of a batch keep clear of each other. (The
        # engine places one pair's moves together, and pairs may share a move.)
        movers = [
            {int(world.ids[f]) for f, _, _ in heuristic.moves(pair)} for pair in batch.tolist()
        ]
        for one, there in moved.items():
            for other, elsewhere in moved.items():
                if one < other and not any({one, other} <= group for group in movers):
                    assert np.linalg.norm(there - elsewhere) >= 2 * radius
        aside = world.moved(moved)
        for pair in batch.tolist():
            path = heuristic.paths.nodes[
                heuristic.paths.offsets[pair] : heuristic.paths.offsets[pair + 1]
            ]
            walk = Walk(0, 0, tuple(world.ids[path].tolist()))
            while walk.state == WALKING:
                walk = step_walk(walk, aside.measurement(walk.at))
            assert walk.state == ARRIVED, (pair, walk)
            vectors[pair] = walk.vector
    again = walked(heuristic, vectors)
    assert (again.resolved == heuristic.resolved).all()
    np.testing.assert_allclose(
        again.estimate[again.resolved], heuristic.estimate[heuristic.resolved], rtol=0, atol=1e-9
    )


def test_a_pair_whose_walk_failed_keeps_its_plain_result():
    world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
    evaluation = evaluate(world.swarm, world.sensor, "shortest-length")
    heuristic = move_source(evaluation, 10)
    resolved = np.flatnonzero(heuristic.resolved)
    failed, arrived = int(resolved[0]), resolved[1:]
    vectors = {int(pair): heuristic.estimate[pair] + 1.0 for pair in arrived}
    after = apply(evaluation, walked(heuristic, vectors))
    plain, pairs = evaluation.pairs, after.pairs
    assert pairs.status[failed] == plain.status[failed]
    assert pairs.path(failed) == plain.path(failed)
    assert (pairs.status[arrived] == SWEET_PATH).all()
    pair = int(arrived[0])
    np.testing.assert_array_equal(pairs.estimate[pair], heuristic.estimate[pair] + 1.0)
    rows = heuristic.paths
    assert pairs.path(pair) == rows.nodes[rows.offsets[pair] : rows.offsets[pair + 1]].tolist()
