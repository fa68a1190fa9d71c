"""The study's sweep: which runs it holds, their cache keys, and running the missing ones.

A run is one (shape, beta, policy, technique). Its results live in a folder
of their own, ``runs/<shape>/beta-<beta>/<policy>/<technique>/``, holding
``pairs.parquet`` (compact or full, core.results.PAIR_COLUMNS) and then
``summary.json``, each written atomically. The
summary records the run's cache key, a hash of everything its numbers depend
on: the points, beta, policy, technique, threshold, sensor, seed and the
software version. A run whose folder holds a summary with the right key is
done; any other run is computed. Runs of one (shape, beta, policy) share the
plain evaluation, so they are computed together as one task.
"""

from __future__ import annotations

import hashlib
import json
import multiprocessing
import os
import signal
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from .. import __version__
from ..core.clouds import Cloud
from ..core.errors import SwazureError
from ..core.evaluate import evaluate
from ..core.fit import LEAST_SQUARES, refine
from ..core.fusion import fuse
from ..core.geometry import make_swarm
from ..core.heuristics import COMPAT_MODES, MOVE_OBSTRUCTING, MOVE_SOURCE, PLAIN, run_technique
from ..core.paths import POLICIES
from ..core.results import (
    COMPACT_PAIRS,
    FULL_PAIRS,
    PAIR_COLUMNS,
    PAIRS_PARQUET_FILE,
    SUMMARY_FILE,
    describe_source,
    write_evaluation,
)
from ..core.sensor import Sensor

#: The published sweep (spec, section 10).
PUBLISHED_BETAS = (0.01, 0.1, 0.2, 0.3, 0.4, 0.5)
PUBLISHED_HEURISTIC_BETAS = (0.3, 0.4, 0.5)
#: Plain Swazure with each sweet pair's estimate fused from up to ``threshold`` paths.
FUSED = "fused"
#: Plain Swazure's pairs estimated by the least-squares fit (core.fit).
FIT = LEAST_SQUARES
RUNS_DIR = "runs"


@dataclass(frozen=True, order=True)
class Technique:
    """Plain Swazure or a heuristic; ``threshold`` is Move Source's T (None otherwise).

    ``compat`` names the heuristic's :data:`~swazure_ros.core.heuristics.COMPAT_MODES`
    entry: the text's (``text``) or the published code's (``published``).
    """

    name: str
    threshold: int | None = None
    compat: str = "text"

    @property
    def label(self) -> str:
        """Folder and column name: ``plain``, ``move-source-T10``, ``...-published``."""
        if self.name == FUSED:
            return f"{FUSED}-K{self.threshold}"
        if self.name == FIT:
            return FIT
        label = self.name if self.threshold is None else f"{self.name}-T{self.threshold}"
        return label if self.compat == "text" else f"{label}-{self.compat}"

    @property
    def title(self) -> str:
        """Name for people: ``Move Source (T = 10)``, ``Move Obstructing (published code)``."""
        names = {PLAIN: "plain Swazure", MOVE_OBSTRUCTING: "Move Obstructing"}
        if self.name == FUSED:
            return f"fused from up to {self.threshold} disjoint paths"
        if self.name == FIT:
            return "least-squares fit"
        if self.name == MOVE_SOURCE:
            title = f"Move Source (T = {self.threshold})"
        else:
            title = names[self.name]
        return title if self.compat == "text" else f"{title} ({self.compat} code)"

    @classmethod
    def parse(cls, text: str) -> Technique:
        """``plain``, ``move-obstructing``, ``move-source`` (T = 10) or ``move-source:T``."""
        name, _, threshold = text.partition(":")
        if name == MOVE_SOURCE:
            try:
                value = int(threshold) if threshold else 10
            except ValueError:
                value = 0
            if value < 1:
                raise SwazureError(f"technique {text!r}: T must be a positive integer")
            return cls(name, value)
        if name in (PLAIN, MOVE_OBSTRUCTING) and not threshold:
            return cls(name)
        raise SwazureError(
            f"unknown technique {text!r}; expected plain, move-obstructing, move-source[:T]"
        )


PLAIN_TECHNIQUE = Technique(PLAIN)
PUBLISHED_TECHNIQUES = (
    Technique(MOVE_OBSTRUCTING),
    Technique(MOVE_SOURCE, 2),
    Technique(MOVE_SOURCE, 10),
)


@dataclass(frozen=True)
class RunSpec:
    """One run of the sweep and the key of its cached results."""

    cloud: str
    beta: float
    policy: str
    technique: Technique
    key: str

    @property
    def folder(self) -> Path:
        """The run's folder relative to the study's output folder."""
        return Path(RUNS_DIR, self.cloud, f"beta-{self.beta:g}", self.policy, self.technique.label)


@dataclass
class StudyPlan:
    """What a study sweeps: clouds (smallest first) x betas x policies, and the heuristics."""

    clouds: list[Cloud]
    sensor: Sensor
    betas: tuple[float, ...] = PUBLISHED_BETAS
    policies: tuple[str, ...] = POLICIES
    techniques: tuple[Technique, ...] = PUBLISHED_TECHNIQUES
    heuristic_betas: tuple[float, ...] = PUBLISHED_HEURISTIC_BETAS
    heuristic_policy: str = "shortest-length"
    sensor_file: str | None = None
    seed: int = 0
    #: Per-pair columns kept: "compact" (what nothing else reproduces) or "full".
    pairs: str = COMPACT_PAIRS
    #: The heuristics' modes, each run for every technique: "text", and "published" too
    #: to put the published code's numbers beside the text's.
    compat: tuple[str, ...] = ("text",)
    #: Above 1: plain Swazure of the heuristic policy also with every sweet pair's estimate
    #: fused from up to this many node-disjoint paths, at every beta.
    fuse: int = 1
    #: Plain Swazure of the heuristic policy also with every pair estimated by the
    #: least-squares fit over the measurement graph, at every beta.
    least_squares: bool = False

    def __post_init__(self) -> None:
        if self.pairs not in PAIR_COLUMNS:
            raise SwazureError(f"unknown per-pair output {self.pairs!r}; expected "
                               f"{', '.join(PAIR_COLUMNS)}")  # fmt: skip
        if not self.clouds:
            raise SwazureError("the study needs at least one point cloud")
        names = [cloud.name for cloud in self.clouds]
        if len(set(names)) != len(names):
            raise SwazureError(f"two clouds share a name: {', '.join(names)}")
        for beta in (*self.betas, *self.heuristic_betas):
            if not 0 < beta <= 1:
                raise SwazureError(f"beta must be in (0, 1], got {beta:g}")
        for policy in (*self.policies, self.heuristic_policy):
            if policy not in POLICIES:
                raise SwazureError(f"unknown policy {policy!r}; expected {', '.join(POLICIES)}")
        if self.fuse < 1:
            raise SwazureError(f"fusion needs at least one path per pair, got {self.fuse}")
        for mode in self.compat:
            if mode not in COMPAT_MODES:
                raise SwazureError(f"unknown compat mode {mode!r}; expected "
                                   f"{', '.join(COMPAT_MODES)}")  # fmt: skip
        self.clouds = sorted(self.clouds, key=lambda cloud: len(cloud.points))
        self.techniques = tuple(
            sorted(
                {
                    replace(technique, compat=mode)
                    for technique in self.techniques
                    if technique != PLAIN_TECHNIQUE
                    for mode in self.compat
                },
                # Each heuristic's text run first, then its published code's.
                key=lambda technique: (
                    technique.name,
                    technique.threshold or 0,
                    technique.compat != "text",
                ),
            )
        )

    def runs(self) -> list[RunSpec]:
        """Every run: plain at each beta and policy, heuristics at the heuristic betas."""
        runs = []
        for cloud in self.clouds:
            digest = cloud_digest(cloud)
            plain = [(beta, policy) for beta in self.betas for policy in self.policies]
            moved = [(beta, self.heuristic_policy) for beta in self.heuristic_betas]
            for beta, policy in dict.fromkeys(plain + moved):
                runs.append(self._spec(cloud.name, digest, beta, policy, PLAIN_TECHNIQUE))
            for beta, policy in moved:
                for technique in self.techniques:
                    runs.append(self._spec(cloud.name, digest, beta, policy, technique))
            for estimator in self.estimators:
                for beta in self.betas:
                    runs.append(
                        self._spec(cloud.name, digest, beta, self.heuristic_policy, estimator)
                    )
        return runs

    @property
    def fused(self) -> Technique | None:
        """The fused runs' technique, or None when the study fuses nothing."""
        return Technique(FUSED, self.fuse) if self.fuse > 1 else None

    @property
    def estimators(self) -> tuple[Technique, ...]:
        """The other estimates of plain Swazure's pairs the study runs: fused, fitted."""
        fitted = (Technique(FIT),) if self.least_squares else ()
        return (*((self.fused,) if self.fused is not None else ()), *fitted)

    def _spec(
        self, cloud: str, digest: str, beta: float, policy: str, technique: Technique
    ) -> RunSpec:
        inputs = {
            "points": digest,
            "beta": beta,
            "policy": policy,
            "technique": technique.name,
            "threshold": technique.threshold,
            "sensor": self.sensor.to_dict(),
            "accurate": self.sensor.accurate,
            "seed": self.seed,
            "version": __version__,
        }
        if technique.compat != "text":  # the text's keys stay those of earlier studies
            inputs["compat"] = technique.compat
        key = hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()
        return RunSpec(cloud, beta, policy, technique, key)


def cloud_digest(cloud: Cloud) -> str:
    """SHA-256 of a cloud's points in cm (float64, C order)."""
    return hashlib.sha256(
        np.ascontiguousarray(cloud.points, dtype=np.float64).tobytes()
    ).hexdigest()


def read_summary(out: Path, spec: RunSpec, pairs: str) -> dict[str, Any] | None:
    """The run's summary if its folder holds complete results under its key, else None.

    Results whose per-pair file keeps other columns than ``pairs`` asks are not done.
    """
    folder = out / spec.folder
    try:
        summary: dict[str, Any] = json.loads((folder / SUMMARY_FILE).read_text())
    except (OSError, ValueError):
        return None
    study = summary.get("study", {})
    if study.get("key") != spec.key or study.get("pairs", FULL_PAIRS) != pairs:
        return None
    if not (folder / PAIRS_PARQUET_FILE).is_file():
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
    pairs: str

    @property
    def weight(self) -> int:
        """Rough cost, to start the longest tasks first."""
        return len(self.cloud.points) ** 2 * (1 + len(self.runs))


def run_task(task: Task) -> list[tuple[RunSpec, float]]:
    """Compute and write every run of ``task``; return each run with its seconds."""
    swarm = make_swarm(task.cloud.points, beta=task.beta, seed=task.seed)
    began = time.perf_counter()
    plain = evaluate(swarm, task.sensor, task.policy)
    plain_seconds = time.perf_counter() - began
    done = []
    for spec in task.runs:
        began = time.perf_counter()
        technique = spec.technique
        if technique.name == FUSED:
            result, heuristic = fuse(plain, technique.threshold or 1), None
        elif technique.name == FIT:
            result, heuristic = refine(plain), None
        else:
            result, heuristic = run_technique(
                plain, technique.name, technique.threshold or 10, COMPAT_MODES[technique.compat]
            )
        seconds = plain_seconds + time.perf_counter() - began
        summary = result.summary
        summary["seconds"] = seconds
        describe_source(summary, task.cloud, task.seed, task.sensor_file)
        summary["study"] = {"key": spec.key, "run": spec.folder.as_posix(), "pairs": task.pairs}
        write_evaluation(
            task.out / spec.folder, result, heuristic, pairs_format="parquet", columns=task.pairs
        )
        done.append((spec, seconds))
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
            plan.pairs,
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

    summaries: dict[RunSpec, dict[str, Any]]
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
    ) -> dict[str, Any] | None:
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
    summaries: dict[RunSpec, dict[str, Any] | None] = {
        spec: read_summary(out, spec, plan.pairs) for spec in specs
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
    complete: dict[RunSpec, dict[str, Any]] = {}
    for spec in specs:
        summary = summaries[spec] or read_summary(out, spec, plan.pairs)
        if summary is None:
            raise SwazureError(f"{out / spec.folder}: the run left no complete results")
        complete[spec] = summary
    return SweepResult(
        complete, len(missing), cached, compute_seconds, time.perf_counter() - began
    )
