"""The whole swarm's computation beside the core engine's evaluation of the same work.

:func:`compute_all` runs the whole swarm's discovery (and a heuristic) over a
:class:`~.swarm.RunningSwarm` and sets it beside the engine's evaluation of
the same work, pair by pair (:func:`same_results`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..core.errors import SwazureError
from ..core.evaluation import Evaluation
from ..core.fit import PATH, check_plain_estimator
from ..core.heuristics.result import MOVE_SOURCE, PLAIN, HeuristicResult
from ..core.heuristics.source import source_body_in_the_way
from ..core.pipeline import EngineRun, RunOptions, run_engine
from ..core.summary import with_source
from ..files.record import Distributed, EngineComparison, RunRecord
from ..protocol.discovery.estimate import evaluation_of
from ..protocol.runs import DiscoveryResult
from ..sim.world import World
from ..view.scene import evaluation_scene
from .swarm import RunningSwarm


@dataclass(frozen=True)
class SwarmComputation:
    """The whole swarm's computation beside the engine's evaluation of the same work."""

    evaluation: Evaluation  # what the swarm computed (its summary is the record's)
    heuristic: HeuristicResult | None  # the moves made, with a technique
    engine: Evaluation  # the core engine's, for the same work
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
    """
    check_plain_estimator(estimator, technique)
    if not swarm.config.whole_world:
        raise SwazureError(
            "every pose by the swarm needs the whole world: SwarmConfig.whole_world"
        )
    world: World = swarm.world
    result = swarm.discover(policy, on_progress=on_progress, estimator=estimator, per_run=per_run)
    if on_discovered is not None:
        on_discovered(result)
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
    spec = swarm.config.world
    found = replace(evaluation.summary, seconds=seconds)
    summary = with_source(found, world.cloud, spec.seed, spec.sensor_file)
    evaluation = replace(evaluation, summary=summary)
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


def _compared(ours: Evaluation, engine: EngineRun, world: World) -> EngineComparison:
    """The swarm's pairs beside the engine's; for Move Source, how many of the engine's
    the source's body at its probe point blocks (what the swarm cannot fly)."""
    comparison = same_results(ours, engine.held)
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


def same_results(ours: Evaluation, engine: Evaluation) -> EngineComparison:
    """Every pair of ``ours`` beside the engine's: how many differ in status, path and
    estimate (to 1e-9 cm; a fit's covariance to 1e-9 of its largest entry)."""
    mine, theirs = ours.pairs, engine.pairs
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
