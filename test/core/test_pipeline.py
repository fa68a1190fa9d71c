"""The engine's pipeline: each stage as the core runs it by hand, blocks or held, timed."""

import doctest
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core import pipeline
from swazure_ros.core.blocks import Budget
from swazure_ros.core.errors import OptionError, SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.fit import refine
from swazure_ros.core.fusion import fuse
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.compat import PUBLISHED
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.pipeline import EngineRun, RunOptions, run_engine
from swazure_ros.core.summary import Source
from swazure_ros.files.cloud_files import load_cloud

from .test_blocks import assert_same_pairs, joined

#: torus:120 at 1.6 x: sweet, blocked and unreachable pairs, a heuristic in a moment.
CLOUD = load_cloud("torus:120", 1.6)
#: The smallest budget: blocks of a few hundred pairs, so the torus has several.
SMALL = Budget(2**20)


@pytest.fixture(scope="module")
def swarm():
    return make_swarm(CLOUD.points, beta=0.5)


def untimed(summary):
    """A summary's document without its times, which differ from run to run."""
    document = summary.as_document()
    document.pop("seconds")
    for part in ("fusion", "fit"):
        if part in document:
            document[part] = {k: v for k, v in document[part].items() if k != "seconds"}
    return document


def same_document(got, want):
    # NaN statistics compare equal as text.
    assert repr(untimed(got)) == repr(untimed(want))


class Blocks:
    """A take that keeps every block it is given, and the heuristic."""

    def __init__(self):
        self.blocks, self.heuristic, self.told = [], None, None

    def __call__(self, hood, blocks, heuristic, blind_pairs):
        self.told = blind_pairs
        self.blocks += list(blocks)
        self.heuristic = heuristic


def test_plain_swazure_runs_in_blocks_unless_the_caller_holds_the_pairs(swarm, sensor):
    kept = Blocks()
    blocked = run_engine(swarm, sensor, RunOptions(), take=kept, budget=SMALL)
    held = run_engine(swarm, sensor, RunOptions(), hold=True, budget=SMALL)
    assert blocked.evaluation is None and len(kept.blocks) > 1
    with pytest.raises(SwazureError, match="block by block"):
        blocked.held  # noqa: B018
    assert kept.told == len(held.held.pairs) == held.summary.pairs.blind_pairs > 1000
    assert_same_pairs(joined(kept.blocks), held.held.pairs)
    same_document(blocked.summary, held.summary)
    want = evaluate(swarm, sensor, "shortest-length")
    assert_same_pairs(held.held.pairs, want.pairs)
    same_document(held.summary, want.summary)


@pytest.mark.parametrize(
    ("options", "by_hand"),
    [
        (
            RunOptions(technique="move-source", threshold=3),
            lambda plain: run_technique(plain, "move-source", 3)[0],
        ),
        (
            RunOptions(technique="move-source", threshold=2, compat="published"),
            lambda plain: run_technique(plain, "move-source", 2, PUBLISHED)[0],
        ),
        (
            RunOptions(technique="move-obstructing"),
            lambda plain: run_technique(plain, "move-obstructing")[0],
        ),
        (RunOptions(fuse=2), lambda plain: fuse(plain, 2)),
        (RunOptions(estimator="least-squares"), lambda plain: refine(plain, "least-squares")),
    ],
    ids=["move-source", "move-source-published", "move-obstructing", "fuse", "least-squares"],
)
def test_each_stage_gives_what_the_core_gives_by_hand(swarm, sensor, options, by_hand):
    want = by_hand(evaluate(swarm, sensor, "shortest-length"))
    kept = Blocks()
    run = run_engine(swarm, sensor, options, hold=True, take=kept)  # blocks: test_regions, below
    assert_same_pairs(run.held.pairs, want.pairs)
    same_document(run.summary, want.summary)
    # A run that holds its pairs gives them to ``take`` once, with the heuristic's moves.
    assert len(kept.blocks) == 1 and kept.blocks[0] is run.held.pairs
    assert kept.heuristic is run.heuristic
    assert (run.heuristic is None) == (options.technique == "plain")


def test_a_shared_plain_run_gives_the_runs_of_a_fresh_one_and_counts_its_seconds(swarm, sensor):
    plain = run_engine(swarm, sensor, RunOptions(), hold=True)
    assert plain.seconds > 0
    # The plain run's seconds, whatever they were, count in every run made from it.
    plain = replace(plain, seconds=1000.0)
    for options in (RunOptions(technique="move-source", threshold=2), RunOptions(fuse=2)):
        shared = run_engine(swarm, sensor, options, plain=plain)
        fresh = run_engine(swarm, sensor, options, hold=True)
        assert_same_pairs(shared.held.pairs, fresh.held.pairs)
        same_document(shared.summary, fresh.summary)
        assert shared.seconds > 1000.0
    again = run_engine(swarm, sensor, RunOptions(), plain=plain)
    assert again.held is plain.held and again.seconds == 1000.0


def test_a_heuristics_summary_seconds_are_plain_swazures_and_its_own(swarm, sensor):
    plain = run_engine(swarm, sensor, RunOptions(), hold=True)
    moved = run_engine(swarm, sensor, RunOptions(technique="move-obstructing"), plain=plain)
    assert plain.summary.seconds is not None and moved.summary.seconds is not None
    assert moved.summary.seconds > plain.summary.seconds
    fused = run_engine(swarm, sensor, RunOptions(fuse=2), plain=plain)
    # Fusion reports its own time apart (summary.fusion.seconds), as swazure evaluate does.
    assert fused.summary.seconds == plain.summary.seconds and fused.seconds > plain.seconds


def test_the_source_is_in_the_summary_held_or_in_blocks(swarm, sensor):
    source = Source.of(CLOUD, 7, "config/sensor.yaml")
    for hold in (False, True):
        run = run_engine(swarm, sensor, RunOptions(), hold=hold, source=source)
        assert run.summary.parameters.source == source
        assert run.summary.as_document()["parameters"]["seed"] == 7
    for hold in (False, True):
        run = run_engine(
            swarm, sensor, RunOptions(technique="move-source"), hold=hold, source=source
        )
        assert run.summary.parameters.source == source
    assert run.held.summary is run.summary
    assert run_engine(swarm, sensor, RunOptions(), hold=True).summary.parameters.source is None


def test_a_run_holding_every_pair_refuses_a_swarm_larger_than_the_memory_free(swarm, sensor):
    tight = Budget(free=1)
    with pytest.raises(SwazureError, match="hold every pair of the swarm at once, about"):
        run_engine(swarm, sensor, RunOptions(technique="move-source"), hold=True, budget=tight)
    with pytest.raises(SwazureError, match="plain Swazure runs in blocks"):
        run_engine(swarm, sensor, RunOptions(), hold=True, budget=tight)
    # In blocks, plain Swazure and a heuristic need no more than a block.
    assert run_engine(swarm, sensor, RunOptions(), budget=tight).summary.pairs.blind_pairs
    moved = run_engine(swarm, sensor, RunOptions(technique="move-source"), budget=tight)
    assert moved.summary.heuristic is not None and moved.summary.heuristic.resolved_pairs


def test_a_take_that_leaves_blocks_unmade_gets_no_summary(swarm, sensor):
    def first_only(hood, blocks, heuristic, blind_pairs):
        next(blocks)

    with pytest.raises(RuntimeError, match="every block"):
        run_engine(swarm, sensor, RunOptions(), take=first_only, budget=SMALL)


def test_a_plain_run_to_start_from_must_be_held_plain_and_of_this_swarm(swarm, sensor):
    held = run_engine(swarm, sensor, RunOptions(), hold=True)
    moved = RunOptions(technique="move-source")
    with pytest.raises(ValueError, match="held"):
        run_engine(swarm, sensor, moved, plain=run_engine(swarm, sensor, RunOptions()))
    with pytest.raises(ValueError, match="not of fewest-hops"):
        run_engine(swarm, sensor, replace(moved, policy="fewest-hops"), plain=held)
    with pytest.raises(ValueError, match="no heuristic"):
        run_engine(swarm, sensor, moved, plain=run_engine(swarm, sensor, moved, plain=held))
    other = make_swarm(CLOUD.points, beta=0.5)
    with pytest.raises(ValueError, match="same swarm"):
        run_engine(other, sensor, moved, plain=held)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (RunOptions(policy="longest"), "policy 'longest'"),
        (RunOptions(technique="move-source", threshold=0), "threshold 0"),
        (RunOptions(fuse=2, technique="move-source"), "drop --technique"),
        (RunOptions(compat="published"), "add --technique"),
    ],
)
def test_options_are_checked_before_anything_runs(swarm, sensor, options, message):
    with pytest.raises((OptionError, SwazureError), match=message):
        run_engine(swarm, sensor, options)


def test_an_engine_run_holds_its_evaluations_summary(swarm, sensor):
    run = run_engine(swarm, sensor, RunOptions(), hold=True)
    other = replace(run.summary, seconds=1.0)
    with pytest.raises(ValueError, match="summary must be its evaluation's"):
        EngineRun(other, 1.0, run.held)


def test_the_examples_run_as_written():
    failed, tried = doctest.testmod(pipeline, optionflags=doctest.ELLIPSIS)
    assert failed == 0 and tried > 0


def test_blocks_and_held_pairs_have_the_same_estimates(swarm, sensor):
    # The estimates, to the bit: a block searches the whole swarm's graphs.
    kept = Blocks()
    run_engine(swarm, sensor, RunOptions(policy="least-error"), take=kept, budget=SMALL)
    held = run_engine(swarm, sensor, RunOptions(policy="least-error"), hold=True)
    np.testing.assert_array_equal(joined(kept.blocks).estimate, held.held.pairs.estimate)


@pytest.mark.parametrize(
    "options",
    [RunOptions(fuse=3), RunOptions(estimator="least-squares"), RunOptions(estimator="swarm-fit")],
    ids=["fuse-3", "least-squares", "swarm-fit"],
)
def test_fusion_and_the_whole_swarms_fits_run_in_blocks_as_held(swarm, sensor, options):
    kept = Blocks()
    blocked = run_engine(swarm, sensor, options, take=kept, budget=SMALL)
    held = run_engine(swarm, sensor, options, hold=True)
    assert blocked.evaluation is None and len(kept.blocks) > 3
    assert_same_pairs(joined(kept.blocks), held.held.pairs)
    same_document(blocked.summary, held.summary)
    assert blocked.summary.pairs.quantiles == "exact"


class Stages:
    """A progress that keeps each stage it is told of, with the units it has advanced."""

    def __init__(self):
        self.stages = []  # [name, total, advanced]

    def start(self, stage, total):
        self.stages.append([stage, total, 0])

    def advance(self, units):
        self.stages[-1][2] += units

    def named(self, prefix):
        return [stage for stage in self.stages if stage[0].startswith(prefix)]


@pytest.mark.parametrize(
    ("estimator", "free", "solves"),
    [
        ("least-squares", None, ["fit: factoring"]),
        ("least-squares", 1, ["fit: solve 1", "fit: covariance, 64 draws"]),
        ("swarm-fit", None, ["fit: solve 1", "fit: covariance, 64 draws"]),
    ],
    ids=["dense", "sparse", "swarm"],
)
def test_a_fit_shows_its_solves_and_the_pairs_go_on_where_they_were(
    swarm, sensor, estimator, free, solves
):
    shown = Stages()
    kept = Blocks()
    budget = Budget(SMALL.memory, free=free)
    options = RunOptions(estimator=estimator)
    run_engine(swarm, sensor, options, take=kept, budget=budget, progress=shown)
    for prefix in solves:
        named = shown.named(prefix)
        assert named and all(advanced == total for _, total, advanced in named), shown.stages
    # Every pair counted once, on "pairs" stages that each resume where the last stopped.
    pairs = [stage for stage in shown.stages if stage[0] == "pairs"]
    total = sum(len(block) for block in kept.blocks)
    assert pairs[-1][1] == total and pairs[-1][2] == total
    assert all(stage[1] == total and stage[2] <= total for stage in pairs)
    assert shown.stages[-1][0] == "pairs"


def test_a_fit_whose_dense_inverse_does_not_fit_is_solved_by_conjugate_gradients(swarm, sensor):
    # Too little memory free for the dense inverse: the same estimates to the conjugate
    # gradients' tolerance, a covariance sampled as the swarm's fit samples it.
    options = RunOptions(estimator="least-squares")
    kept = Blocks()
    run_engine(swarm, sensor, options, take=kept, budget=Budget(SMALL.memory, free=1))
    held = run_engine(swarm, sensor, options, hold=True).held.pairs
    swarms = run_engine(swarm, sensor, RunOptions(estimator="swarm-fit"), hold=True).held.pairs
    sparse = joined(kept.blocks)
    np.testing.assert_allclose(sparse.estimate, held.estimate, rtol=0, atol=1e-7)
    assert not np.array_equal(sparse.covariance, held.covariance, equal_nan=True)
    np.testing.assert_array_equal(sparse.covariance, swarms.covariance)
