"""The engine's pipeline: plain Swazure, then a heuristic, fusion or a fit, timed, in one call.

:func:`run_engine` is how every caller runs the engine: ``swazure evaluate``
and ``api.evaluate``, the study's runs, the engine's side of a swarm's
comparison, and the warm-up of the kernels. Its stages, in order::

    plain Swazure -> a heuristic -> fusion -> a fit -> where the swarm came from

Plain Swazure, a heuristic after it, fused or fitted by the whole swarm's fit,
for a caller that does not need every pair held, runs a block of pairs at a
time within ``budget.memory`` (:mod:`.blocks`, :mod:`.heuristics.regions`),
each block through the heuristic, fusion or the fit before it is tallied;
each source's own fit, or a caller that
asks to ``hold`` the pairs (a snapshot, the study, a swarm's comparison)
holds every pair at once (:func:`.evaluate.evaluate`). Both give the same
numbers and the same pairs, in the same order. The caller says what it
needs; the pipeline decides how.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np

from .blocks import BlockedEvaluation, Budget, evaluate_blocked, whole_swarm_bytes, with_decaying
from .errors import OptionError, SwazureError
from .evaluate import evaluate
from .evaluation import Evaluation, PairResults
from .fit import (
    BLOCKED_ESTIMATORS,
    ESTIMATORS,
    PATH,
    WholeFitEstimates,
    check_plain_estimator,
    needs_decaying,
    refine,
)
from .fusion import Fusion, fuse
from .geometry import Swarm
from .heuristics.compat import COMPAT_MODES
from .heuristics.folding import run_technique
from .heuristics.regions import TechniqueBlocks
from .heuristics.result import MAX_THRESHOLD, MOVE_SOURCE, PLAIN, TECHNIQUES, HeuristicResult
from .neighbourhood import Neighbourhood
from .paths import LEAST_ERROR, POLICIES, SHORTEST_LENGTH
from .progress import SILENT, Progress
from .sensor import Sensor
from .summary import Source, Summary

#: Where a run's pairs go as they are made: ``take(hood, blocks, heuristic, blind_pairs)``.
#: It must go through ``blocks`` (write them, join them): the summary needs every pair
#: tallied. FLS ids are ``hood.swarm.cloud_index[...]`` of the pairs' indices;
#: ``heuristic`` is the moves of a heuristic's run held whole (None otherwise: a run
#: made in blocks brings each block's in its pairs, ``heuristics.result.MovedPairs``);
#: ``blind_pairs`` is how many pairs the blocks hold, known before the first block.
Take = Callable[[Neighbourhood, Iterator[PairResults], HeuristicResult | None, int], None]


#: Where a run in blocks searches its decaying paths: SD_vis held whole, near each pair,
#: or near each pair wherever that can be proven (AUTO: plain or a heuristic, by
#: shortest-length or fewest-hops).
AUTO, HELD, NEAR = "auto", "held", "near"
DECAYING_SEARCHES = (AUTO, HELD, NEAR)


@dataclass(frozen=True)
class RunOptions:
    """What a run is asked for: ``swazure evaluate``'s options of the same names."""

    policy: str = SHORTEST_LENGTH
    technique: str = PLAIN
    threshold: int = 10  # Move Source: steps of r probed per direction
    compat: str = "text"  # the heuristics as the paper's text ("text") or code ("published")
    fuse: int = 1  # sweet paths fused per pair
    estimator: str = PATH
    # Move Source: the source's own body at its probe point may block the helper's view of
    # the target, as the swarm flies it (--source-body); False: the spec's rule.
    source_body: bool = False
    # Where a run in blocks searches its decaying paths (--decaying): in SD_vis held whole
    # (HELD), or each pair's in a region around it (NEAR, core.local_paths): the same paths.
    # AUTO: NEAR where it can be proven and the run reads only paths, else HELD.
    decaying: str = AUTO

    def check(self) -> None:
        """OptionError for a value that is none of its choices; SwazureError for options that
        do not go together (the command line's messages)."""
        for name, choices in (
            ("policy", POLICIES),
            ("technique", TECHNIQUES),
            ("compat", tuple(COMPAT_MODES)),
            ("estimator", ESTIMATORS),
            ("decaying", DECAYING_SEARCHES),
        ):
            value = getattr(self, name)
            if value not in choices:
                raise OptionError(f"{name} {value!r}: expected one of {', '.join(choices)}")
        _whole_number("threshold", self.threshold, 1, MAX_THRESHOLD)
        _whole_number("fuse", self.fuse, 1, None)
        if self.fuse > 1 and self.technique != PLAIN:
            raise SwazureError("--fuse combines plain Swazure's paths; drop --technique")
        check_plain_estimator(self.estimator, self.technique, self.fuse)
        if self.compat != "text" and self.technique == PLAIN:
            raise SwazureError(f"--compat {self.compat} changes the heuristics; add --technique")
        if self.source_body and self.technique != MOVE_SOURCE:
            raise SwazureError("--source-body changes Move Source: add --technique move-source")
        if self.decaying == NEAR and (self.fuse > 1 or self.estimator != PATH):
            raise SwazureError(
                "--decaying near is for paths: fusion and the fits read SD_vis whole"
            )
        if self.decaying == NEAR and self.policy == LEAST_ERROR:
            raise SwazureError("--decaying near needs a policy whose costs are bounded per cm: "
                               "fewest-hops or shortest-length")  # fmt: skip

    @property
    def near_pairs(self) -> bool:
        """Whether a run in blocks searches its decaying paths near their pairs
        (:mod:`.local_paths`): asked, or by default where the run reads no decaying pair
        but those its paths hop over (not fusion, not a fit) and the policy's costs are
        bounded per cm (not least-error)."""
        if self.decaying == AUTO:
            return self.fuse == 1 and self.estimator == PATH and self.policy != LEAST_ERROR
        return self.decaying == NEAR

    @property
    def in_blocks(self) -> bool:
        """Whether the run can be made a block of pairs at a time: plain Swazure, a
        heuristic (:mod:`.heuristics.regions`), fusion or a fit of the whole swarm (each
        pair's estimate its own: :mod:`.fusion`, :class:`.fit.WholeFitEstimates`); not each
        source's own fit."""
        return self.estimator == PATH or self.estimator in BLOCKED_ESTIMATORS


def _whole_number(name: str, value: object, low: int, high: int | None) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise OptionError(f"{name} must be a whole number, got {value!r}")
    if value < low or (high is not None and value > high):
        top = f" to {high}" if high is not None else " or more"
        raise OptionError(f"{name} {value}: must be {low}{top}")


@dataclass(frozen=True)
class EngineRun:
    """One run of the pipeline: its summary, the time it took, and its pairs when held.

    Two times, for two questions. ``summary.seconds`` is what ``swazure
    evaluate`` reports: plain Swazure's computation and a heuristic's (fusion
    and a fit give theirs in ``summary.fusion.seconds`` and
    ``summary.fit.seconds``; a fit's is also in ``summary.seconds``, as
    :func:`.fit.refine` counts it). ``seconds`` is every stage of this run,
    s: plain Swazure (made here, or the ``plain`` run given, its own
    ``seconds``), the heuristic, fusion and the fit: what the study reports
    per run, and a swarm's comparison as the engine's time.
    """

    summary: Summary
    seconds: float
    evaluation: Evaluation | None = None  # every pair; None for a run made block by block
    heuristic: HeuristicResult | None = None  # a heuristic's moves, when held

    def __post_init__(self) -> None:
        if self.evaluation is not None and self.evaluation.summary is not self.summary:
            raise ValueError("an EngineRun's summary must be its evaluation's")

    @property
    def held(self) -> Evaluation:
        """Every pair of the run at once; SwazureError for a run made block by block."""
        if self.evaluation is None:
            raise SwazureError("this run was made block by block: run_engine(..., hold=True)")
        return self.evaluation


def run_engine(
    swarm: Swarm,
    sensor: Sensor,
    options: RunOptions,
    *,
    plain: EngineRun | None = None,
    hold: bool = False,
    take: Take | None = None,
    budget: Budget | None = None,
    source: Source | None = None,
    progress: Progress | None = None,
) -> EngineRun:
    """Every ordered blind pair of ``swarm``, as ``options`` ask: plain Swazure, a heuristic,
    fusion or a fit, timed.

    Parameters
    ----------
    swarm : Swarm
        The FLSs (``core.geometry.make_swarm``): centres (N, 3) and radius, cm.
    sensor : Sensor
        Their sensor.
    options : RunOptions
        Policy, technique (threshold, compat), fusion and estimator; checked here.
    plain : EngineRun, optional
        A held run of plain Swazure of this ``swarm``, ``sensor`` and policy to
        start from (the study shares one between runs); its ``seconds`` count
        in this run's.
    hold : bool, default False
        The caller needs every pair held at once (``EngineRun.held``): a
        snapshot, a comparison. Without it, plain Swazure and a heuristic run
        in blocks.
    take : Take, optional
        Where the pairs go as they are made (:data:`Take`): block by block, or
        once for a run that holds them. Without it, blocks are let go.
    budget : Budget, optional
        Bytes a block of plain Swazure's pairs may hold (default 2 GiB), and
        bytes free for a run that holds every pair (None: not checked).
    source : Source, optional
        Where the swarm came from, for the summary's parameters (None: left out).
    progress : Progress, optional
        Told each stage's start and advance.

    Returns
    -------
    EngineRun
        The summary (``core.summary.Summary``), the seconds, and for a run that
        holds its pairs the evaluation and a heuristic's moves (a run in
        blocks gives them to ``take``).

    Raises
    ------
    OptionError
        An option that is none of its choices or out of range.
    SwazureError
        Options that do not go together; every pair held needs over ``budget.free``.
    ValueError
        ``plain`` is no held plain run of this swarm, sensor and policy.

    Examples
    --------
    >>> from swazure_ros import api
    >>> from swazure_ros.core.pipeline import RunOptions, run_engine
    >>> setup = api.build_swarm("torus:120", scale=1.6, beta=0.5)
    >>> swarm, sensor = setup.swarm, setup.sensor
    >>> plain = run_engine(swarm, sensor, RunOptions(), hold=True)
    >>> moved = run_engine(swarm, sensor, RunOptions(technique="move-source"), plain=plain)
    >>> moved.summary.heuristic.technique, moved.seconds > plain.seconds
    ('move-source', True)
    """
    options.check()
    budget = budget or Budget()
    if plain is None and options.in_blocks and not hold:
        return _in_blocks(swarm, sensor, options, take, budget, source, progress or SILENT)
    if plain is None:
        _check_room(swarm, sensor, budget, source)
        plain = _held_plain(swarm, sensor, options.policy, progress)
    _check_plain(plain, swarm, sensor, options.policy)
    run = _with_source(_stages(plain, options, progress), source)
    if take is not None:
        pairs = run.held.pairs
        take(run.held.hood, iter([pairs]), run.heuristic, len(pairs))
    return run


def _in_blocks(
    swarm: Swarm,
    sensor: Sensor,
    options: RunOptions,
    take: Take | None,
    budget: Budget,
    source: Source | None,
    progress: Progress,
) -> EngineRun:
    """Plain Swazure a block of pairs at a time, then a heuristic, fusion or a fit on each
    block: each block to ``take`` as it is made (a heuristic's moves in its pairs:
    ``MovedPairs``)."""
    # Plain Swazure and the heuristics read no decaying pair but those the paths hop over:
    # their decaying paths may be searched near their pairs (checked: not fusion, not a fit).
    near = options.near_pairs
    plain = evaluate_blocked(swarm, sensor, options.policy, budget, progress, near_pairs=near)
    stage = _block_stage(plain, options, budget, progress)
    run: BlockedEvaluation | TechniqueBlocks = plain
    if options.technique != PLAIN:
        compat = COMPAT_MODES[options.compat]
        run = TechniqueBlocks(
            plain, options.technique, options.threshold, compat, options.source_body
        )
    blocks = run.blocks(progress)
    if take is None:
        for _ in blocks:
            pass
    else:
        take(plain.hood, blocks, None, len(plain.lean.blind))
    # RuntimeError when ``take`` left blocks unmade: the summary needs every pair.
    summary = run.summary()
    if stage is None:
        return _with_source(EngineRun(summary, run.seconds), source)
    return _with_source(stage.run(summary, run.seconds), source)


@dataclass
class _BlockStage:
    """Fusion or a fit made per block of a :class:`.blocks.BlockedEvaluation`, timed."""

    fusion: Fusion | None
    fit: WholeFitEstimates | None
    seconds: float = 0.0  # spent within the blocks, whose time the run counts too

    def __call__(self, hood: Neighbourhood, pairs: PairResults, progress: Progress) -> PairResults:
        began = time.perf_counter()
        if self.fusion is not None:
            pairs = self.fusion.block(hood, pairs)
        if self.fit is not None:
            pairs = self.fit.block(pairs, progress)
        self.seconds += time.perf_counter() - began
        return pairs

    def run(self, summary: Summary, seconds: float) -> EngineRun:
        """The run's summary with the stage's facts, and times as :func:`_stages` gives them."""
        plain = seconds - self.seconds
        if self.fusion is not None:
            facts = self.fusion.facts()
            summary = replace(summary, seconds=plain, fusion=facts)
            return EngineRun(summary, plain + facts.seconds)
        assert self.fit is not None  # a stage is fusion or a fit
        fit = self.fit.facts()
        took = plain + (fit.seconds or 0.0)
        return EngineRun(replace(summary, seconds=took, fit=fit), took)


def _block_stage(
    run: BlockedEvaluation, options: RunOptions, budget: Budget, progress: Progress
) -> _BlockStage | None:
    """The stage each block of ``run`` goes through before its tally: fusion, a fit or none.

    A fit's measurements are the whole swarm's, taken before the first block;
    its decaying pairs in sight are judged first where one may join two parts
    of ``S_vis`` (:func:`.fit.needs_decaying`)."""
    if options.fuse > 1:
        run.stage = _BlockStage(Fusion(options.fuse, options.policy, budget.exact_values), None)
    elif options.estimator != PATH:
        if run.lean.whole is None and needs_decaying(run.lean.sweet):
            run.lean = with_decaying(run.lean, progress)
        fit = WholeFitEstimates(
            run.hood, options.estimator, exact_values=budget.exact_values, free=budget.free,
            progress=progress,
        )  # fmt: skip
        run.stage = _BlockStage(None, fit)
    return run.stage if isinstance(run.stage, _BlockStage) else None


def _held_plain(swarm: Swarm, sensor: Sensor, policy: str, progress: Progress | None) -> EngineRun:
    """Plain Swazure with every pair held at once, timed."""
    began = time.perf_counter()
    evaluation = evaluate(swarm, sensor, policy, progress)
    return EngineRun(evaluation.summary, time.perf_counter() - began, evaluation)


def _stages(plain: EngineRun, options: RunOptions, progress: Progress | None) -> EngineRun:
    """The stages after plain Swazure: a heuristic, fusion, a fit, each timed."""
    evaluation, seconds = plain.held, plain.seconds
    heuristic: HeuristicResult | None = None
    if options.technique != PLAIN:
        began = time.perf_counter()
        if progress is not None:
            progress.start(options.technique, 1)
        evaluation, heuristic = run_technique(
            evaluation,
            options.technique,
            options.threshold,
            COMPAT_MODES[options.compat],
            options.source_body,
        )
        took = time.perf_counter() - began
        seconds += took
        # swazure evaluate's seconds: plain Swazure's and the heuristic's.
        timed = (evaluation.summary.seconds or 0.0) + took
        evaluation = replace(evaluation, summary=replace(evaluation.summary, seconds=timed))
    if options.fuse > 1:
        began = time.perf_counter()
        evaluation = fuse(evaluation, options.fuse)
        seconds += time.perf_counter() - began
    if options.estimator != PATH:
        began = time.perf_counter()
        if progress is not None:
            progress.start(options.estimator, 1)
        evaluation = refine(evaluation, options.estimator)
        seconds += time.perf_counter() - began
    return EngineRun(evaluation.summary, seconds, evaluation, heuristic)


def _with_source(run: EngineRun, source: Source | None) -> EngineRun:
    """``run`` with ``source`` in its summary's parameters (unchanged for None)."""
    if source is None:
        return run
    summary = replace(run.summary, parameters=replace(run.summary.parameters, source=source))
    evaluation = None if run.evaluation is None else replace(run.evaluation, summary=summary)
    return replace(run, summary=summary, evaluation=evaluation)


def _check_room(swarm: Swarm, sensor: Sensor, budget: Budget, source: Source | None) -> None:
    """SwazureError when every pair of ``swarm`` held at once needs more than ``budget.free``."""
    if budget.free is None:
        return
    need = whole_swarm_bytes(swarm, sensor)  # a counting pass over the candidate pairs
    if need <= budget.free:
        return
    name = "the swarm" if source is None else source.cloud
    raise SwazureError(
        f"{name}: --technique, --estimator local-least-squares and --snapshot hold every "
        f"pair of the swarm at once, about {need / 2**30:.1f} GB for {swarm.size} FLSs; "
        f"this machine has {budget.free / 2**30:.1f} GB free (plain Swazure runs in blocks, "
        f"and so do --fuse, --estimator least-squares and swarm-fit)"
    )


def _check_plain(plain: EngineRun, swarm: Swarm, sensor: Sensor, policy: str) -> None:
    """ValueError unless ``plain`` is a held run of plain Swazure of this swarm and policy."""
    evaluation, summary = plain.evaluation, plain.summary
    if evaluation is None:
        raise ValueError("`plain` must be held (run_engine(..., hold=True)), not made in blocks")
    if evaluation.hood.swarm is not swarm or evaluation.hood.sensor is not sensor:
        raise ValueError("`plain` must be a run of the same swarm and sensor")
    if evaluation.policy != policy:
        raise ValueError(f"`plain` is a run of {evaluation.policy}, not of {policy}")
    if plain.heuristic is not None or summary.fusion is not None or summary.fit is not None:
        raise ValueError("`plain` must be plain Swazure: no heuristic, fusion or fit")
