"""A study's plan: which runs it holds (shape, beta, policy, technique) and their cache keys.

A run's cache key is a hash of everything its numbers depend on: the points,
beta, policy, technique, threshold, sensor, seed and the software version.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..core.clouds import Cloud
from ..core.errors import SwazureError
from ..core.fit import LEAST_SQUARES
from ..core.heuristics.compat import COMPAT_MODES
from ..core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE, PLAIN
from ..core.paths import POLICIES
from ..core.pipeline import RunOptions
from ..core.sensor import Sensor
from ..files.results import COMPACT_PAIRS, NO_PAIRS, PAIR_COLUMNS

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

    def options(self, policy: str) -> RunOptions:
        """What the engine's pipeline runs for this technique under ``policy``."""
        if self.name == FUSED:
            return RunOptions(policy, fuse=self.threshold or 1)
        if self.name == FIT:
            return RunOptions(policy, estimator=FIT)
        return RunOptions(policy, self.name, self.threshold or 10, self.compat)

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
    #: Keep every run's per-pair file; by default only those a figure reads (figure_runs).
    keep_pairs: bool = False
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

    @property
    def histogram_shape(self) -> str:
        """The shape whose pairs the figures draw: the dragon when the study has it, else the
        first (smallest)."""
        for cloud in self.clouds:
            if "dragon" in cloud.name:
                return cloud.name
        return self.clouds[0].name

    @property
    def histogram_beta(self) -> float:
        """The beta of the error histogram: 0.5 when the study has it, else its largest."""
        return 0.5 if 0.5 in self.betas else max(self.betas)

    def figure_runs(self) -> set[tuple[str, float, str, Technique]]:
        """(shape, beta, policy, technique) of the runs whose per-pair file a figure reads.

        The error histogram: the histogram shape's plain runs at the histogram
        beta, every policy; the error by hops: its plain and least-squares runs
        of the heuristic policy at the largest beta. Every table and every
        other figure is drawn from the summaries.
        """
        shape = self.histogram_shape
        runs = {(shape, self.histogram_beta, policy, PLAIN_TECHNIQUE) for policy in self.policies}
        fitted = [estimator for estimator in self.estimators if estimator.name == FIT]
        if fitted:
            beta, policy = max(self.betas), self.heuristic_policy
            runs |= {(shape, beta, policy, one) for one in (PLAIN_TECHNIQUE, fitted[0])}
        return runs

    def pairs_kept(self, spec: RunSpec) -> str:
        """The per-pair columns ``spec``'s run keeps (``pairs``), or "none" when it keeps none."""
        wanted = (spec.cloud, spec.beta, spec.policy, spec.technique)
        return self.pairs if self.keep_pairs or wanted in self.figure_runs() else NO_PAIRS

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
