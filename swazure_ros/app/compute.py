"""The whole swarm's computation beside the core engine's evaluation of the same work.

:func:`compute_all` runs the whole swarm's discovery (and a heuristic) over a
:class:`~.swarm.RunningSwarm` and sets it beside the engine's evaluation of
the same work, pair by pair (:func:`same_pairs`). A launcher whose world holds
only its own FLSs' pairs compares plain Swazure a block of sources at a time,
beside the engine's blocks (``core.blocks``): no process then holds every
pair's results, nor the whole swarm's neighbourhood.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..core.blocks import BlockedEvaluation, Budget, evaluate_blocked, with_decaying
from ..core.errors import SwazureError
from ..core.evaluation import Evaluation, PairResults
from ..core.fit import PATH, check_plain_estimator
from ..core.heuristics.result import MOVE_SOURCE, PLAIN, HeuristicResult
from ..core.heuristics.source import source_body_in_the_way
from ..core.pair_statistics import PairTally, summarise
from ..core.pipeline import EngineRun, RunOptions, Take, run_engine
from ..core.progress import SILENT
from ..core.summary import Summary, with_source
from ..files.record import Distributed, EngineComparison, RunRecord
from ..protocol.discovery.reported import ReportedPairs, evaluation_of
from ..protocol.runs import DiscoveryResult
from ..sim.world import World
from ..view.scene import evaluation_scene
from .swarm import RunningSwarm

#: Bytes a block of the engine's run may hold while the launcher compares with it: less
#: than a run of its own may (``core.blocks.DEFAULT_MEMORY``), since the launcher holds
#: its share of the world and every source's estimates beside it. torus:30000's engine
#: alone peaked at 1,794 MB with 2 GiB blocks, at 930 MB with these, in the same time
#: (45.2 s and 44.5 s; 256 MiB blocks: 775 MB and 50.6 s).
COMPARISON_MEMORY = 512 * 2**20


@dataclass(frozen=True)
class SwarmComputation:
    """The whole swarm's computation beside the engine's evaluation of the same work."""

    #: What the swarm computed (its summary is the record's); None when compared block by
    #: block, its pairs given to ``take`` as they were read.
    evaluation: Evaluation | None
    heuristic: HeuristicResult | None  # the moves made, with a technique
    engine: Evaluation | None  # the core engine's, for the same work; None as evaluation
    record: RunRecord  # the run as data: summary, traffic, the engine's, identity


def compute_all(
    swarm: RunningSwarm,
    policy: str,
    technique: str = PLAIN,
    threshold: int = 10,
    on_discovered: Callable[[DiscoveryResult], None] | None = None,
    on_progress: Callable[[str], None] | None = None,
    estimator: str = PATH,
    per_run: int | None = None,
    source_body: bool = False,
    take: Take | None = None,
) -> SwarmComputation:
    """Every FLS's pose relative to every blind neighbour, by the swarm, and by the engine.

    With a ``technique`` other than plain, the swarm then makes that heuristic's
    moves. ``on_discovered`` hears the discovery run's result as soon as it is in;
    ``on_progress`` how far each run is, every PROGRESS_PERIOD s. With the
    ``estimator`` local-least-squares each source fits what it hears, with
    swarm-fit the swarm solves its fit, and the engine does the same
    (``core.pipeline.run_engine``, every pair held). ``per_run``: the
    most sources one discovery run searches for (``RunningSwarm.discover``).
    ``source_body``: Move Source, by the swarm and the engine, takes a helper only
    where the source's body at its probe point leaves its view of the target clear.
    ``take`` gets the swarm's pairs (:data:`core.pipeline.Take`): a run's
    held whole as one block, a run compared block by block as it is read.

    Where the launcher's world holds only its own FLSs' pairs
    (``SwarmConfig.whole_world`` False), plain Swazure's path estimates are
    compared block by block (:func:`compare_in_blocks`), and the result holds
    no evaluation; a heuristic or a fit then is a SwazureError.
    """
    check_plain_estimator(estimator, technique)
    if not swarm.config.whole_world and (technique != PLAIN or estimator != PATH):
        raise SwazureError(
            f"the swarm's {technique if technique != PLAIN else estimator} needs every pair "
            "at once: SwarmConfig.whole_world"
        )
    world: World = swarm.world
    result = swarm.discover(policy, on_progress=on_progress, estimator=estimator, per_run=per_run)
    if on_discovered is not None:
        on_discovered(result)
    if not swarm.config.whole_world:
        return _in_blocks(swarm, result, policy, take, on_progress)
    evaluation = evaluation_of(world.hood, policy, result.outcome.estimates)
    if swarm.view is not None:
        title = f"{world.cloud.name}, {policy}: poses found by the swarm"
        pairs = swarm.config.view.pairs if swarm.config.view else ()
        swarm.view.show(evaluation_scene(evaluation, title, pairs=pairs))
    heuristic, moved = None, None
    if technique != PLAIN:
        if on_progress is not None:
            on_progress(f"planning {technique}")
        moved = swarm.make_moves(
            evaluation, technique, threshold, on_progress=on_progress, source_body=source_body
        )
        evaluation, heuristic = moved.outcome.evaluation, moved.outcome.heuristic
        if swarm.view is not None:
            title = f"{world.cloud.name}, {policy}, {technique}: after the swarm's moves"
            scene = evaluation_scene(evaluation, title, heuristic=heuristic, pairs=pairs)
            swarm.view.show(scene)
    options = RunOptions(
        policy, technique, threshold, estimator=estimator, source_body=source_body
    )
    engine = run_engine(world.swarm, world.sensor, options, hold=True)
    seconds = result.seconds + (moved.seconds if moved is not None else 0.0)
    summary = _sourced(swarm, replace(evaluation.summary, seconds=seconds))
    evaluation = replace(evaluation, summary=summary)
    if take is not None:
        take(world.hood, iter([evaluation.pairs]), heuristic, len(evaluation.pairs))
    record = RunRecord(
        "spawn",
        seconds,
        summary,
        engine=engine.summary,
        engine_seconds=engine.seconds,
        comparison=_compared(evaluation, engine, world),
        bring_up=swarm.bring_up,
        distributed=Distributed.of(result, moved),
    )
    return SwarmComputation(evaluation, heuristic, engine.held, record)


def _sourced(swarm: RunningSwarm, summary: Summary) -> Summary:
    """``summary`` with where the swarm came from: its cloud, seed and sensor file."""
    spec = swarm.config.world
    return with_source(summary, swarm.world.cloud, spec.seed, spec.sensor_file)


def _in_blocks(
    swarm: RunningSwarm,
    result: DiscoveryResult,
    policy: str,
    take: Take | None,
    on_progress: Callable[[str], None] | None,
) -> SwarmComputation:
    """Plain Swazure's discovery ``result`` beside the engine's, block by block."""
    world = swarm.world
    if on_progress is not None:
        on_progress("comparing the pairs with the engine's, block by block")
    reported = ReportedPairs(world.swarm.cloud_index, result.outcome.estimates)
    engine = evaluate_blocked(world.swarm, world.sensor, policy, Budget(COMPARISON_MEMORY), SILENT)
    summary, comparison = compare_in_blocks(reported, engine, result.seconds, take)
    record = RunRecord(
        "spawn",
        result.seconds,
        _sourced(swarm, summary),
        engine=engine.summary(),
        engine_seconds=engine.seconds,
        comparison=comparison,
        bring_up=swarm.bring_up,
        distributed=Distributed.of(result, None),
    )
    return SwarmComputation(None, None, None, record)


def compare_in_blocks(
    reported: ReportedPairs,
    engine: BlockedEvaluation,
    seconds: float,
    take: Take | None = None,
) -> tuple[Summary, EngineComparison]:
    """The swarm's ``reported`` pairs beside each of ``engine``'s blocks, read and tallied
    a block at a time: the swarm's summary (``seconds`` its time) and the comparison.

    ``take`` gets the swarm's blocks as they are read; every block is made.
    """
    tally = PairTally(engine.lean.budget.exact_values)
    parts: list[EngineComparison] = []

    def ours() -> Iterator[PairResults]:
        for theirs in engine.blocks(SILENT):
            mine = _reported_block(reported, engine, theirs)
            parts.append(same_pairs(mine, theirs))
            tally.add(mine)
            yield mine

    if take is None:
        deque(ours(), maxlen=0)
    else:
        take(engine.hood, ours(), None, len(engine.lean.blind))
    return summarise(engine.hood, engine.policy, tally, seconds), joined_comparison(parts)


def _reported_block(
    reported: ReportedPairs, engine: BlockedEvaluation, theirs: PairResults
) -> PairResults:
    """The swarm's pairs of the engine's block ``theirs``. A reported path over a decaying
    hop the engine's neighbourhood does not hold yet (its sweet pairs alone: no pair of
    its blocks so far needed more) brings the decaying pairs in."""
    try:
        return reported.pairs(engine.hood, theirs.source, theirs.target)
    except ValueError:
        if engine.lean.whole is not None:
            raise
        engine.lean = with_decaying(engine.lean, SILENT)
        return reported.pairs(engine.hood, theirs.source, theirs.target)


def _compared(ours: Evaluation, engine: EngineRun, world: World) -> EngineComparison:
    """The swarm's pairs beside the engine's; for Move Source, how many of the engine's
    the source's body at its probe point blocks (what the swarm cannot fly)."""
    comparison = same_pairs(ours.pairs, engine.held.pairs)
    if engine.heuristic is None or engine.heuristic.technique != MOVE_SOURCE:
        return comparison
    blocked = source_body_in_the_way(engine.heuristic, world.swarm)
    return replace(comparison, source_body=len(blocked))


def run_failure(record: RunRecord) -> str | None:
    """Why a swarm's run is not the engine's work, in one line; None when it is."""
    reasons = []
    distributed = record.distributed
    if distributed is not None and distributed.departed:
        gone = distributed.departed
        shown = ", ".join(map(str, gone[:10])) + (", ..." if len(gone) > 10 else "")
        reasons.append(f"{len(gone)} FLSs did not take part to the end ({shown})")
    if distributed is not None and distributed.incomplete:
        reasons.append("radio deliveries were lost for good")
    comparison = record.comparison
    if comparison is not None and not comparison.identical:
        reasons.append(f"the pairs are not the engine's ({comparison.describe()})")
    return "; ".join(reasons) or None


def same_pairs(mine: PairResults, theirs: PairResults) -> EngineComparison:
    """Every pair of ``mine`` beside the engine's ``theirs``: how many differ in status,
    path and estimate (to 1e-9 cm; a fit's covariance to 1e-9 of its largest entry)."""
    if len(mine) != len(theirs):
        # Not the same pairs: none of them is compared.
        return EngineComparison(len(mine), len(theirs), None, None, None)
    status = int((mine.status != theirs.status).sum())
    paths = not np.array_equal(mine.nodes, theirs.nodes)
    with np.errstate(invalid="ignore"):
        far = int((np.abs(mine.estimate - theirs.estimate) > 1e-9).any(axis=1).sum())
        if mine.covariance is not None and theirs.covariance is not None:
            # A fit's covariance too, relative to its largest entry (cm^2 of any size).
            scale = np.abs(theirs.covariance).max(axis=(1, 2))
            apart = np.abs(mine.covariance - theirs.covariance).max(axis=(1, 2))
            far += int((apart > 1e-9 * scale).sum())
    return EngineComparison(len(mine), len(theirs), status, far, paths)


def joined_comparison(parts: Sequence[EngineComparison]) -> EngineComparison:
    """The comparison of blocks' pairs taken together (:func:`same_pairs` of each): their
    counts summed; where some block's pairs were not compared, none are."""
    pairs = sum(part.pairs for part in parts)
    engine_pairs = sum(part.engine_pairs for part in parts)
    if any(part.statuses is None or part.estimates is None for part in parts):
        return EngineComparison(pairs, engine_pairs, None, None, None)
    return EngineComparison(
        pairs,
        engine_pairs,
        sum(part.statuses or 0 for part in parts),
        sum(part.estimates or 0 for part in parts),
        any(bool(part.paths) for part in parts),
    )
