"""A swarm evaluated block by block gives the pairs and the summary of the whole evaluation."""

import json
from dataclasses import fields, replace

import numpy as np
import pytest

from swazure_ros.core import blocks
from swazure_ros.core.blocks import (
    PAIR_BYTES,
    BlockedEvaluation,
    Budget,
    evaluate_blocked,
    lean_neighbourhood,
    ranges,
    with_decaying,
)
from swazure_ros.core.evaluate import evaluate, evaluate_pairs
from swazure_ros.core.evaluation import PairResults
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.graph import Graph
from swazure_ros.core.neighbourhood import NeighbourGraphs
from swazure_ros.core.neighbours import ordered_blind_pairs, pair_counts
from swazure_ros.core.pair_statistics import PairTally
from swazure_ros.core.progress import SILENT
from swazure_ros.files.cloud_files import load_cloud

from ..conftest import A, B, C, D, K, scene

#: The smallest budget: blocks of a few hundred pairs, so that small swarms have many.
SMALL = Budget(2**20)


def about_blocks(pairs, blocks):
    """A budget that cuts ``pairs`` ordered blind pairs into about ``blocks`` blocks."""
    return Budget(max(2**20, 2 * PAIR_BYTES * pairs // blocks))


def shape(name):
    return make_swarm(load_cloud(name).points, beta=0.5)


def joined(blocks):
    """The blocks' pair results as one, path offsets rebased."""
    joined = {}
    for field in fields(PairResults):
        parts = [getattr(block, field.name) for block in blocks]
        if field.name == "offsets":
            base = np.cumsum([0] + [part[-1] for part in parts[:-1]])
            parts = [parts[0]] + [part[1:] + shift for part, shift in zip(parts[1:], base[1:])]
        joined[field.name] = None if parts[0] is None else np.concatenate(parts)
    return PairResults(**joined)


def assert_same_pairs(got, want):
    for field in fields(PairResults):
        a, b = getattr(got, field.name), getattr(want, field.name)
        if b is None:
            assert a is None, field.name
        else:
            np.testing.assert_array_equal(a, b, err_msg=field.name)


def deferred(run):
    """``run`` with its decaying pairs left out until a block needs them."""
    return BlockedEvaluation(replace(run.lean, whole=None), run.policy)


def at_once(run):
    """``run`` with its decaying pairs in sight from the start."""
    return BlockedEvaluation(with_decaying(run.lean, SILENT), run.policy)


@pytest.mark.parametrize("defer", [False, True], ids=["decaying-at-once", "decaying-deferred"])
@pytest.mark.parametrize("cloud", ["torus:300", "helix:200", "cube:125"])
def test_blocks_give_the_pairs_and_summary_of_the_whole_evaluation(sensor, cloud, defer):
    swarm = shape(cloud)
    whole = evaluate(swarm, sensor, "fewest-hops")
    run = evaluate_blocked(swarm, sensor, "fewest-hops", about_blocks(len(whole.pairs), 6), SILENT)
    run = deferred(run) if defer else at_once(run)
    run.tally = PairTally()  # exact quantiles, whatever the budget
    blocks = list(run.blocks(SILENT))
    assert 4 <= len(blocks) <= 8
    assert_same_pairs(joined(blocks), whole.pairs)
    summary = run.summary()
    assert summary.pairs.quantiles == "exact"
    summary, expected = replace(summary, seconds=None), replace(whole.summary, seconds=None)
    assert json.dumps(summary.as_document()) == json.dumps(expected.as_document())  # NaN as NaN


def test_a_blocked_pair_falls_back_to_its_decaying_path_as_the_whole_evaluation_does(sensor):
    swarm = scene(A, B, C, K, D)
    whole = evaluate(swarm, sensor, "fewest-hops")
    run = deferred(evaluate_blocked(swarm, sensor, "fewest-hops", SMALL, SILENT))
    assert_same_pairs(joined(list(run.blocks(SILENT))), whole.pairs)
    assert run.lean.whole is not None  # the blocked pair (A, C) searched the decaying pairs


def test_each_block_is_evaluated_once_the_first_to_need_decaying_pairs_too(sensor, monkeypatch):
    # Whether a block needs them is known from the parts of S_vis, before its searches.
    evaluated = []
    monkeypatch.setattr(
        blocks,
        "evaluate_pairs",
        lambda hood, *a, **k: evaluated.append(hood) or evaluate_pairs(hood, *a, **k),
    )
    swarm = scene(A, B, C, K, D)
    whole = evaluate(swarm, sensor, "fewest-hops")
    run = deferred(evaluate_blocked(swarm, sensor, "fewest-hops", SMALL, SILENT))
    made = list(run.blocks(SILENT))
    assert_same_pairs(joined(made), whole.pairs)
    assert len(evaluated) == len(made) and evaluated[-1] is run.lean.whole


def test_the_sweet_neighbourhood_lets_its_graphs_go_once_the_decaying_pairs_join(sensor):
    swarm = scene(A, B, C, K, D)
    run = deferred(evaluate_blocked(swarm, sensor, "fewest-hops", SMALL, SILENT))
    sweet = run.hood  # what a writer of the blocks holds (its swarm's ids)
    evaluate_pairs(sweet, "fewest-hops")
    assert sweet.graphs.sweet_visible is not None
    for _ in run.blocks(SILENT):
        pass
    assert run.hood is run.lean.whole is not sweet
    left = [
        kept.name
        for kept in fields(NeighbourGraphs)
        if getattr(sweet.graphs, kept.name) is not None
    ]
    assert left == []  # the whole neighbourhood builds its own over the same pairs
    assert run.hood.graphs.sweet_visible is not None


def test_the_blocks_find_each_graph_s_components_once(sensor, monkeypatch):
    # Every block searches S_vis and SD_vis; their components are the run's, not the block's.
    found = []
    components = Graph.components
    monkeypatch.setattr(
        Graph, "components", lambda graph: found.append(graph) or components(graph)
    )
    swarm = shape("cube:125")
    run = at_once(evaluate_blocked(swarm, sensor, "fewest-hops", about_blocks(4000, 6), SILENT))
    assert len(list(run.blocks(SILENT))) >= 4
    assert len(found) == len({id(graph) for graph in found}) <= 3  # S_all, S_vis, SD_vis


def test_a_swarm_whose_sweet_paths_are_all_in_sight_never_judges_its_decaying_pairs(sensor):
    swarm = shape("helix:200")
    run = deferred(evaluate_blocked(swarm, sensor, "fewest-hops", SMALL, SILENT))
    for _ in run.blocks(SILENT):
        pass
    assert run.lean.whole is None
    assert run.summary().pairs.sweet_pct == 100.0


def test_the_lean_neighbourhood_keeps_sweet_pairs_and_decaying_pairs_in_sight(sensor):
    swarm = shape("helix:200")
    whole = evaluate(swarm, sensor, "fewest-hops").hood
    lean = with_decaying(lean_neighbourhood(swarm, sensor, SMALL, SILENT), SILENT)
    assert len(lean.blocks) > 1
    kept = (whole.pairs.range_class == 2) | ((whole.pairs.range_class == 3) & whole.visible)
    for name in ("first", "second", "distance", "tracking", "range_class"):
        np.testing.assert_array_equal(
            getattr(lean.whole.pairs, name), getattr(whole.pairs, name)[kept]
        )
    np.testing.assert_array_equal(lean.whole.visible, whole.visible[kept])
    assert lean.whole.counts == whole.counts


@pytest.mark.parametrize("decaying", [False, True], ids=["sweet-only", "decaying-kept"])
def test_blocks_found_side_by_side_give_the_neighbourhood_one_at_a_time_gives(
    sensor, decaying, monkeypatch
):
    swarm = shape("helix:200")
    # The smallest budget keeps no decaying pair; 100 bytes a candidate keeps them all.
    budget = Budget(100 * int(pair_counts(swarm, sensor).sum())) if decaying else SMALL
    runs = []
    for at_once in (1, 2, 3):
        monkeypatch.setattr(blocks, "BLOCKS_AT_ONCE", at_once)
        runs.append(lean_neighbourhood(swarm, sensor, budget, SILENT))
    one = runs[0]
    assert len(one.blocks) > 1 and (one.whole is not None) == decaying
    for other in runs[1:]:
        hoods = [(other.sweet, one.sweet)] + ([(other.whole, one.whole)] if decaying else [])
        for got, want in hoods:
            for name in ("first", "second", "distance", "tracking", "range_class"):
                np.testing.assert_array_equal(getattr(got.pairs, name), getattr(want.pairs, name))
            np.testing.assert_array_equal(got.visible, want.visible)
            assert got.counts == want.counts
        np.testing.assert_array_equal(other.blind.rows, one.blind.rows)
        np.testing.assert_array_equal(other.blind.targets, one.blind.targets)


def test_the_blind_rows_hold_the_whole_evaluation_s_ordered_blind_pairs_in_32_bits(sensor):
    swarm = shape("helix:200")
    lean = lean_neighbourhood(swarm, sensor, SMALL, SILENT)
    sources, targets = ordered_blind_pairs(evaluate(swarm, sensor, "fewest-hops").hood.pairs)
    assert len(lean.blocks) > 1 and len(lean.blind) == len(targets) > 0
    assert lean.blind.targets.dtype == np.int32
    got = lean.blind.block(0, swarm.size)
    assert [part.dtype for part in got] == [np.int64, np.int64]
    np.testing.assert_array_equal(got[0], sources)
    np.testing.assert_array_equal(got[1], targets)
    middle = np.flatnonzero((sources >= 50) & (sources < 120))
    np.testing.assert_array_equal(lean.blind.block(50, 120)[1], targets[middle])


def test_the_summary_waits_for_every_block(sensor):
    run = evaluate_blocked(shape("torus:300"), sensor, "fewest-hops", SMALL, SILENT)
    next(iter(run.blocks(SILENT)))
    with pytest.raises(RuntimeError, match="every block"):
        run.summary()


def test_ranges_cut_weights_into_runs_within_the_limit():
    assert ranges(np.array([3, 3, 3, 3]), 6) == [(0, 2), (2, 4)]
    assert ranges(np.array([10, 1, 1]), 5) == [(0, 1), (1, 3)]  # a heavy item alone
    assert ranges(np.array([0, 0]), 5) == [(0, 2)]


def test_a_budget_below_one_mebibyte_is_refused():
    with pytest.raises(ValueError, match="at least 1 MiB"):
        Budget(1000)
