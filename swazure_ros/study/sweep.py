"""The study's sweep: running the runs of a plan (:mod:`.plan`) that are missing.

A run is one (shape, beta, policy, technique). Its results live in a folder
of their own, ``runs/<shape>/beta-<beta>/<policy>/<technique>/``, holding
``pairs.parquet`` (compact or full, files.results.PAIR_COLUMNS; only for the
runs a figure reads, unless the plan keeps every run's) and then
``summary.json``, each written atomically. The
summary records the run's cache key, a hash of everything its numbers depend
on: the points, beta, policy, technique, threshold, sensor, seed and the
software version. A run whose folder holds a summary with the right key is
done; any other run is computed. Runs of one (shape, beta, policy) share the
plain evaluation, so they are computed together as one task.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..core.clouds import Cloud
from ..core.errors import SwazureError
from ..core.geometry import make_swarm
from ..core.pipeline import RunOptions, run_engine
from ..core.sensor import Sensor
from ..core.summary import Source, StudyRun, Summary
from ..files.results import (
    COMPACT_PAIRS,
    FULL_PAIRS,
    NO_PAIRS,
    PAIRS_PARQUET_FILE,
    SUMMARY_FILE,
    write_evaluation,
)
from ..files.runs import read_summary as read_run_summary
from .plan import PLAIN_TECHNIQUE, RUNS_DIR, RunSpec, StudyPlan, Technique


def read_summary(out: Path, spec: RunSpec, pairs: str) -> Summary | None:
    """The run's summary if its folder holds complete results under its key, else None.

    Results whose per-pair file keeps other columns than ``pairs`` asks are not
    done; a run that keeps none (``pairs`` "none") is done whatever it kept. A
    summary that cannot be read (cut short, or of another version) is not done.
    """
    folder = out / spec.folder
    try:
        summary = read_run_summary(folder / SUMMARY_FILE)
    except SwazureError:
        return None
    study = summary.study
    if study is None or study.key != spec.key:
        return None
    if pairs == NO_PAIRS:
        return summary
    if study.pairs != pairs or not (folder / PAIRS_PARQUET_FILE).is_file():
        return None
    return summary


@dataclass
class Task:
    """Runs that share one plain evaluation: one cloud, beta and policy."""

    cloud: Cloud
    beta: float
    policy: str
    runs: list[RunSpec]
    sensor: Sensor
    sensor_file: str | None
    seed: int
    out: Path
    pairs: dict[RunSpec, str]  # each run's per-pair columns kept, or "none"

    @property
    def weight(self) -> int:
        """Rough cost, to start the longest tasks first."""
        return len(self.cloud.points) ** 2 * (1 + len(self.runs))


def run_task(task: Task) -> list[tuple[RunSpec, float]]:
    """Compute and write every run of ``task``; return each run with its seconds.

    The runs share one plain evaluation; a run's seconds are the plain
    evaluation's and its own (``core.pipeline.EngineRun.seconds``).
    """
    swarm = make_swarm(task.cloud.points, beta=task.beta, seed=task.seed)
    source = Source.of(task.cloud, task.seed, task.sensor_file)
    plain = run_engine(swarm, task.sensor, RunOptions(task.policy), hold=True, source=source)
    done = []
    for spec in task.runs:
        options = spec.technique.options(task.policy)
        run = run_engine(swarm, task.sensor, options, plain=plain, source=source)
        kept = task.pairs[spec]
        study = StudyRun(spec.key, spec.folder.as_posix(), kept)
        summary = replace(run.summary, seconds=run.seconds, study=study)
        write_evaluation(
            task.out / spec.folder,
            replace(run.held, summary=summary),
            run.heuristic,
            pairs_format=NO_PAIRS if kept == NO_PAIRS else "parquet",
            columns=FULL_PAIRS if kept == FULL_PAIRS else COMPACT_PAIRS,
        )
        done.append((spec, run.seconds))
    return done


def plan_tasks(plan: StudyPlan, out: Path, missing: Sequence[RunSpec]) -> list[Task]:
    """Group the missing runs into tasks, longest first."""
    clouds = {cloud.name: cloud for cloud in plan.clouds}
    groups: dict[tuple[str, float, str], list[RunSpec]] = {}
    for spec in missing:
        groups.setdefault((spec.cloud, spec.beta, spec.policy), []).append(spec)
    tasks = [
        Task(
            clouds[name],
            beta,
            policy,
            runs,
            plan.sensor,
            plan.sensor_file,
            plan.seed,
            out,
            {spec: plan.pairs_kept(spec) for spec in runs},
        )
        for (name, beta, policy), runs in groups.items()
    ]
    return sorted(tasks, key=lambda task: -task.weight)


def remove_partial_files(out: Path) -> int:
    """Delete temporary files that a killed run left behind; return how many."""
    removed = 0
    runs = out / RUNS_DIR
    if runs.is_dir():
        for stale in runs.rglob(".*.*"):
            if stale.is_file():
                stale.unlink()
                removed += 1
    return removed


def _init_worker(threads: int) -> None:
    # The parent handles Ctrl-C and terminates the pool; workers must not print tracebacks.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import numba

    numba.set_num_threads(threads)


def execute(tasks: Sequence[Task], jobs: int, on_done: Callable[[RunSpec, float], None]) -> None:
    """Run ``tasks`` in this process (``jobs`` 1) or in ``jobs`` worker processes."""
    if jobs <= 1 or len(tasks) <= 1:
        for task in tasks:
            for spec, seconds in run_task(task):
                on_done(spec, seconds)
        return
    threads = max(1, (os.cpu_count() or 1) // jobs)
    # spawn: the parent may already run numba's threads, and fork would copy them.
    context = multiprocessing.get_context("spawn")
    pool = context.Pool(min(jobs, len(tasks)), initializer=_init_worker, initargs=(threads,))
    try:
        for done in pool.imap_unordered(run_task, tasks):
            for spec, seconds in done:
                on_done(spec, seconds)
        pool.close()
    finally:
        # terminate() also covers an exception or Ctrl-C in the parent; a run cut
        # short leaves only a temporary file, removed by the next study.
        pool.terminate()
        pool.join()


@dataclass
class SweepResult:
    """Summaries of every run of a plan, and what this call had to compute."""

    summaries: dict[RunSpec, Summary]
    computed: int
    cached: int
    compute_seconds: float
    wall_seconds: float
    _index: dict[tuple[str, float, str, Technique], RunSpec] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._index = {
            (spec.cloud, spec.beta, spec.policy, spec.technique): spec for spec in self.summaries
        }

    def spec(
        self, cloud: str, beta: float, policy: str, technique: Technique = PLAIN_TECHNIQUE
    ) -> RunSpec | None:
        """The run of these parameters, or None when the plan has no such run."""
        return self._index.get((cloud, beta, policy, technique))

    def find(
        self, cloud: str, beta: float, policy: str, technique: Technique = PLAIN_TECHNIQUE
    ) -> Summary | None:
        """The summary of one run, or None when the plan has no such run."""
        spec = self.spec(cloud, beta, policy, technique)
        return None if spec is None else self.summaries[spec]

    def specs(self) -> Iterator[RunSpec]:
        """Every run, in plan order."""
        return iter(self.summaries)


class SweepProgress:
    """Interface of progress reports: the total once, then each finished run."""

    def start(self, total: int, cached: int) -> None:
        """The sweep has ``total`` runs, ``cached`` of them already done."""

    def run_done(self, spec: RunSpec, seconds: float) -> None:
        """``spec`` finished after ``seconds`` of computation."""

    def close(self) -> None:
        """The sweep ended."""


def sweep(
    plan: StudyPlan, out: Path, jobs: int = 1, progress: SweepProgress | None = None
) -> SweepResult:
    """Compute the plan's missing runs into ``out``; return every run's summary."""
    began = time.perf_counter()
    progress = progress or SweepProgress()
    remove_partial_files(out)
    specs = plan.runs()
    summaries: dict[RunSpec, Summary | None] = {
        spec: read_summary(out, spec, plan.pairs_kept(spec)) for spec in specs
    }
    missing = [spec for spec, summary in summaries.items() if summary is None]
    cached = len(specs) - len(missing)
    compute_seconds = 0.0

    def on_done(spec: RunSpec, seconds: float) -> None:
        nonlocal compute_seconds
        compute_seconds += seconds
        progress.run_done(spec, seconds)

    progress.start(len(specs), cached)
    try:
        execute(plan_tasks(plan, out, missing), jobs, on_done)
    finally:
        progress.close()
    complete: dict[RunSpec, Summary] = {}
    for spec in specs:
        summary = summaries[spec] or read_summary(out, spec, plan.pairs_kept(spec))
        if summary is None:
            raise SwazureError(f"{out / spec.folder}: the run left no complete results")
        complete[spec] = summary
    return SweepResult(
        complete, len(missing), cached, compute_seconds, time.perf_counter() - began
    )
