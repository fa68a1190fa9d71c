"""A heuristic run block by block gives the pairs, moves and summary of the run held whole."""

import json
from dataclasses import fields, replace

import numpy as np
import pytest

from swazure_ros.core.blocks import evaluate_blocked
from swazure_ros.core.clouds import cube_lattice
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import PairResults
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.compat import COMPAT_MODES
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.heuristics.regions import TechniqueBlocks
from swazure_ros.core.pipeline import RunOptions, run_engine
from swazure_ros.core.progress import SILENT
from swazure_ros.files.results import write_evaluation, write_pair_blocks

from .sensors import stochastic
from .test_blocks import about_blocks

#: A 4 x 4 x 4 block of FLSs 2.6 cm apart, jittered, r = 1 cm: 2,696 ordered blind pairs,
#: 600 of them blocked, in every block of a few hundred pairs.
POINTS = cube_lattice(64) * 2.6 + np.random.default_rng(0).normal(0.0, 0.1, (64, 3))
POLICY = "shortest-length"
#: (technique, threshold, compat): both heuristics, as the text and as published.
CASES = [
    ("move-obstructing", 10, "text"),
    ("move-obstructing", 10, "published"),
    ("move-source", 3, "text"),
    ("move-source", 2, "published"),
]


@pytest.fixture(scope="module")
def swarm():
    return make_swarm(POINTS, radius=1.0)


def in_blocks(swarm, sensor, technique, threshold, compat, blocks=6):
    """The held run of ``technique`` and the same in about ``blocks`` blocks (its blocks)."""
    whole = evaluate(swarm, sensor, POLICY)
    held, moves = run_technique(whole, technique, threshold, COMPAT_MODES[compat])
    budget = about_blocks(len(whole.pairs), blocks)
    plain = evaluate_blocked(swarm, sensor, POLICY, budget, SILENT)
    run = TechniqueBlocks(plain, technique, threshold, COMPAT_MODES[compat])
    return held, moves, run, list(run.blocks(SILENT))


def untimed(summary):
    return json.dumps(replace(summary, seconds=None).as_document())  # NaN as NaN


def assert_same_pairs_but_moves(got_blocks, want):
    for field in fields(PairResults):
        if field.name == "covariance":
            continue
        parts = [getattr(block, field.name) for block in got_blocks]
        if field.name == "offsets":
            base = np.cumsum([0] + [part[-1] for part in parts[:-1]])
            parts = [parts[0]] + [part[1:] + shift for part, shift in zip(parts[1:], base[1:])]
        np.testing.assert_array_equal(
            np.concatenate(parts), getattr(want, field.name), err_msg=field.name
        )


@pytest.mark.parametrize(("technique", "threshold", "compat"), CASES)
def test_a_heuristic_in_blocks_writes_the_held_runs_pairs_and_summary(
    tmp_path, swarm, sensor, technique, threshold, compat
):
    held, moves, run, blocks = in_blocks(swarm, sensor, technique, threshold, compat)
    assert len(blocks) >= 4
    # Several blocks try pairs and resolve some: the blocks are not one in disguise.
    assert sum(block.heuristic.resolved.any() for block in blocks) >= 3
    assert_same_pairs_but_moves(blocks, held.pairs)
    summary = run.summary()
    assert summary.pairs.quantiles == "exact"
    assert untimed(summary) == untimed(held.summary)
    # The per-pair file, moves and all, byte for byte: each block brings its moves.
    _, want = write_evaluation(tmp_path, held, moves)
    got = write_pair_blocks(tmp_path / "blocks", run.plain.hood, POLICY, iter(blocks))
    assert want is not None and got is not None
    assert got.read_bytes() == want.read_bytes()
    if technique == "move-source":
        assert b"flown_distance" in want.read_bytes()[:1000]


def test_move_source_in_blocks_measures_each_probe_as_the_held_run_does(tmp_path):
    # A noisy sensor draws per measured pair, and the k-th resolved pair's probe is FLS N + k:
    # the blocks carry the count of pairs resolved before them.
    swarm = make_swarm(POINTS, radius=1.0)
    held, _, run, blocks = in_blocks(swarm, stochastic(seed=3), "move-source", 3, "text")
    assert sum(block.heuristic.resolved.any() for block in blocks) >= 3
    estimates = np.concatenate([block.estimate for block in blocks])
    np.testing.assert_array_equal(estimates, held.pairs.estimate)
    assert untimed(run.summary()) == untimed(held.summary)


@pytest.mark.parametrize(("technique", "threshold", "compat"), CASES[::2])
def test_run_engine_runs_a_heuristic_in_blocks_unless_the_pairs_are_held(
    swarm, sensor, technique, threshold, compat
):
    options = RunOptions(POLICY, technique, threshold, compat)
    taken = []
    budget = about_blocks(2696, 6)
    run = run_engine(
        swarm,
        sensor,
        options,
        budget=budget,
        take=lambda hood, blocks, moves, _: taken.extend(blocks),
    )
    held = run_engine(swarm, sensor, options, hold=True)
    assert run.evaluation is None and run.heuristic is None and len(taken) >= 4
    assert_same_pairs_but_moves(taken, held.held.pairs)
    assert untimed(run.summary) == untimed(held.summary)
    resolved = np.concatenate([block.heuristic.resolved for block in taken])
    np.testing.assert_array_equal(resolved, held.heuristic.resolved)


def test_the_summary_of_a_heuristic_in_blocks_waits_for_every_block(swarm, sensor):
    plain = evaluate_blocked(swarm, sensor, POLICY, about_blocks(2696, 6), SILENT)
    run = TechniqueBlocks(plain, "move-source", 2)
    next(iter(run.blocks(SILENT)))
    with pytest.raises(RuntimeError, match="every block"):
        run.summary()
