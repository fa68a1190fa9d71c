"""app.compute: a swarm's pairs beside the engine's, as a record; and when a swarm's run is
not the engine's work, it says so in one line."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.app.compute import (
    compare_in_blocks,
    joined_comparison,
    run_failure,
    same_pairs,
)
from swazure_ros.core.blocks import BlockedEvaluation, Budget, evaluate_blocked
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import DECAYING_PATH, Evaluation
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.observe import observations
from swazure_ros.core.progress import SILENT
from swazure_ros.core.sensor import DECAYING
from swazure_ros.files.record import Distributed, EngineComparison, RunRecord
from swazure_ros.files.results import write_evaluation, write_pair_blocks
from swazure_ros.protocol.discovery.estimate import Estimates
from swazure_ros.protocol.discovery.reported import ReportedPairs, evaluation_of
from swazure_ros.protocol.loops import RunOptions, discover
from swazure_ros.sim.world import WorldSpec

from ..conftest import SCENE

SAME = EngineComparison(120, 120)
POLICY = "shortest-length"


def record(comparison: EngineComparison, departed: list[int] | None = None, incomplete=False):
    distributed = Distributed(1.0, 3, 0, departed or [], {}, {}, incomplete=incomplete)
    return RunRecord("spawn", 1.0, None, comparison=comparison, distributed=distributed)


@pytest.fixture
def engine(sensor) -> Evaluation:
    return evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")


def test_pairs_that_are_the_engines_are_identical(engine, sensor):
    again = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")
    comparison = same_pairs(again.pairs, engine.pairs)
    assert comparison == EngineComparison(len(engine.pairs), len(engine.pairs), 0, 0, False)
    assert comparison.identical and comparison.describe() == "yes"


def test_pairs_that_differ_are_counted_by_what_differs(engine):
    pairs = engine.pairs
    status, estimate, nodes = pairs.status.copy(), pairs.estimate.copy(), pairs.nodes.copy()
    status[0] = 1 - status[0] if status[0] < 2 else 0
    estimate[1:3] += 1e-6  # two estimates 1e-6 cm off: beyond the 1e-9 cm allowed
    estimate[3] += 1e-12  # one within it
    nodes[0] = nodes[-1]
    ours = replace(engine, pairs=replace(pairs, status=status, estimate=estimate, nodes=nodes))
    comparison = same_pairs(ours.pairs, engine.pairs)
    assert comparison == EngineComparison(len(pairs), len(pairs), 1, 2, True)
    assert not comparison.identical
    assert comparison.describe() == "no: 1 statuses, 2 estimates differ; paths differ: True"


def test_pairs_of_another_number_are_not_compared_one_by_one(engine, sensor):
    fewer = evaluate(make_swarm(np.array(SCENE[:3]), radius=0.5), sensor, "shortest-length")
    comparison = same_pairs(fewer.pairs, engine.pairs)
    found, known = len(fewer.pairs), len(engine.pairs)
    assert found < known
    assert comparison == EngineComparison(found, known, None, None, None)
    assert not comparison.identical
    assert comparison.describe() == f"no: {found} pairs reported, the engine has {known}"


def test_blocks_compared_apart_add_up_and_one_not_compared_leaves_all_uncompared():
    parts = [EngineComparison(10, 10, 0, 2, False), EngineComparison(5, 5, 1, 0, True)]
    assert joined_comparison(parts) == EngineComparison(15, 15, 1, 2, True)
    assert joined_comparison([*parts[:1], EngineComparison(4, 5, None, None, None)]) == (
        EngineComparison(14, 15, None, None, None)
    )
    assert joined_comparison([SAME, SAME]).identical


def test_a_run_equal_to_the_engine_is_no_failure():
    assert run_failure(record(SAME)) is None


def test_pairs_that_differ_are_a_failure_that_says_what_differs():
    failure = run_failure(record(EngineComparison(0, 120, None, None, None)))
    assert failure == "the pairs are not the engine's (no: 0 pairs reported, the engine has 120)"


def test_departed_flss_are_named_even_when_the_pairs_agree():
    failure = run_failure(record(SAME, departed=list(range(12))))
    assert failure == "12 FLSs did not take part to the end (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, ...)"


def test_lost_deliveries_are_a_failure():
    assert run_failure(record(SAME, incomplete=True)) == "radio deliveries were lost for good"


@pytest.fixture(scope="module")
def discovered():
    """torus:200's world and an in-memory discovery of it: every source's estimates."""
    world = WorldSpec("torus:200", scale=1.6, beta=0.5).build()
    outcome = discover(
        observations(world.hood), world.ids, world.sensor, world.swarm.radius, POLICY, RunOptions()
    )
    return world, outcome.estimates


def blocked(world) -> BlockedEvaluation:
    """The engine's run of ``world`` in blocks of a few hundred pairs: its decaying pairs
    left out until a block needs them (1 MiB holds too few of its candidate pairs)."""
    run = evaluate_blocked(world.swarm, world.sensor, POLICY, Budget(2**20), SILENT)
    assert run.lean.whole is None and len(run.sources()) > 3
    return run


def test_pairs_compared_block_by_block_are_those_held_at_once_and_written_alike(
    discovered, tmp_path
):
    world, found = discovered
    held = evaluation_of(world.hood, POLICY, found)
    blocks: list[int] = []

    def counted(pairs):
        for block in pairs:
            blocks.append(len(block))
            yield block

    def take(hood, pairs, heuristic, count):
        assert heuristic is None and count == len(held.pairs)
        assert write_pair_blocks(tmp_path / "blocks", hood, POLICY, counted(pairs)) is not None

    (tmp_path / "blocks").mkdir()
    (tmp_path / "held").mkdir()
    engine = blocked(world)
    summary, comparison = compare_in_blocks(ReportedPairs(world.ids, found), engine, 2.5, take)
    assert len(blocks) > 3 and sum(blocks) == len(held.pairs)
    assert comparison.identical and comparison.pairs == len(held.pairs)
    # Tallied as the engine tallies its blocks (with 1 MiB its quantiles are sketched).
    assert summary == replace(engine.summary(), seconds=2.5)
    assert summary.pairs.blind_pairs == held.summary.pairs.blind_pairs
    write_evaluation(tmp_path / "held", held)
    assert (tmp_path / "blocks" / "pairs.csv").read_bytes() == (
        tmp_path / "held" / "pairs.csv"
    ).read_bytes()


def test_block_by_block_a_pair_not_reported_and_an_estimate_off_are_found(discovered):
    world, found = discovered
    sources = sorted(found)
    changed = dict(found)
    del changed[sources[5]]  # a source that reported nothing
    table = Estimates.of(changed[sources[-1]])
    vector = table.vector.copy()
    vector[0] += 1e-6  # beyond the 1e-9 cm allowed
    changed[sources[-1]] = replace(table, vector=vector)
    _, comparison = compare_in_blocks(ReportedPairs(world.ids, changed), blocked(world), 1.0)
    missing = len(found[sources[5]])
    assert missing > 0
    assert comparison.engine_pairs - comparison.pairs == missing
    assert comparison.statuses is None and not comparison.identical
    # Every source reporting, one estimate off: counted, in the last block.
    changed[sources[5]] = found[sources[5]]
    _, comparison = compare_in_blocks(ReportedPairs(world.ids, changed), blocked(world), 1.0)
    assert (comparison.statuses, comparison.estimates, comparison.paths) == (0, 1, False)


def test_block_by_block_a_swarm_that_reported_nothing_differs_in_every_pair(discovered):
    world, _ = discovered
    engine = blocked(world)
    _, comparison = compare_in_blocks(ReportedPairs(world.ids, {}), engine, 1.0)
    assert comparison.pairs == 0 and comparison.engine_pairs == engine.summary().pairs.blind_pairs
    assert not comparison.identical


def test_a_reported_decaying_hop_brings_the_decaying_pairs_into_the_blocks(discovered):
    # A swarm that is not the engine may report a path over a decaying hop where the
    # engine's blocks need none: it is read, and counted as differing.
    world, found = discovered
    hood = world.hood
    decaying = hood.pairs.range_class == DECAYING
    near = {(int(a), int(b)) for a, b in zip(hood.pairs.first, hood.pairs.second, strict=True)}
    near |= {(b, a) for a, b in near}
    far = {
        (int(a), int(b))
        for a, b in zip(hood.pairs.first[decaying], hood.pairs.second[decaying], strict=True)
    }
    far |= {(b, a) for a, b in far}
    source = sorted(found)[0]
    table = Estimates.of(found[source])
    row = world.index(source)
    target_row = world.index(int(table.targets[0]))
    via = next(d for d in range(world.swarm.size) if (row, d) in far and (d, target_row) in near)
    path = np.array([source, int(world.ids[via]), int(table.targets[0])])
    offsets = table.path_offsets
    path_ids = np.concatenate([path, table.path_ids[offsets[1] :]])
    status = table.status.copy()
    status[0] = DECAYING_PATH
    changed = dict(found)
    path_offsets = np.r_[0, offsets[1:] - offsets[1] + len(path)]
    changed[source] = replace(table, status=status, path_ids=path_ids, path_offsets=path_offsets)
    run = blocked(world)
    _, comparison = compare_in_blocks(ReportedPairs(world.ids, changed), run, 1.0)
    assert run.lean.whole is not None  # brought in for the swarm's path
    assert comparison.statuses == 1 and comparison.paths is True
