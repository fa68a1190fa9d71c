"""A run's summary (spec, section 6) as typed, frozen records, and its ``summary.json`` document.

:class:`Summary` is built once where the run's pairs are tallied
(:func:`.pair_statistics.summarise`); a later stage (a heuristic, fusion, a fit,
where the swarm came from) makes a new one, never changes it. Its
:meth:`Summary.as_document` is exactly what ``summary.json`` holds, key for
key and in order; :meth:`Summary.from_document` reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Literal

from .clouds import Cloud, Resampled
from .metrics import Stats
from .tally import SKETCH_RELATIVE_ERROR

#: A JSON object as ``json.loads`` gives it: what crosses a file boundary.
Document = dict[str, Any]

#: Whether a summary's real quantiles are exact, or sketched past the tally's bound.
Quantiles = Literal["exact", "sketched"]
_SKETCHED = f"sketched, relative error {SKETCH_RELATIVE_ERROR:g}"


def _stats(document: Document | None) -> Stats | None:
    return None if document is None else Stats(**document)


def _documents(record: object, omit_none: bool = False) -> Document:
    """A frozen record's fields as JSON values, in order: Stats as objects, tuples as lists."""
    out: Document = {}
    for one in fields(record):  # type: ignore[arg-type]
        value = getattr(record, one.name)
        if value is None and omit_none:
            continue
        if isinstance(value, Stats):
            value = value.as_document()
        elif isinstance(value, tuple):
            value = [list(item) if isinstance(item, tuple) else item for item in value]
        out[one.name] = value
    return out


@dataclass(frozen=True)
class PairStatistics:
    """The per-pair fields of a summary (spec, section 6): counts, shares in %, statistics."""

    blind_pairs: int
    sweet_pairs: int
    decaying_pairs: int
    no_path_pairs: int
    sweet_pct: float
    decaying_pct: float
    no_path_pct: float
    blocked_pairs: int
    no_sweet_path_pairs: int
    distance_error_pct: Stats
    # By class of pair: a decaying hop's error is far larger, and a mean over both
    # hides the sweet pairs' (a fit's 1.2 % mean could be 0.01 % and 3.9 %).
    distance_error_pct_sweet_paths: Stats
    distance_error_pct_decaying_paths: Stats
    alpha_deg: Stats
    theta_deg: Stats
    phi_deg: Stats
    hops: Stats
    hops_sweet_paths: Stats
    hops_decaying_paths: Stats
    sweet_connected_pairs: int
    obstructed_path_pct: float
    obstructing_flss_per_path: Stats
    predicted_error_cm: Stats
    # How often the estimate's error is within its predicted error (section "Fusion").
    within_predicted_pct: float
    # Counts of obstructed paths by their number of obstructing FLSs (index = number),
    # so that box plots and quantiles can be drawn without the per-pair file.
    obstructing_flss_histogram: tuple[int, ...]
    quantiles: Quantiles  # exact, or sketched past the tally's bound (core.tally)

    def as_document(self) -> Document:
        """These fields as summary.json holds them."""
        document = _documents(self)
        document["quantiles"] = "exact" if self.quantiles == "exact" else _SKETCHED
        return document

    @classmethod
    def from_document(cls, document: Document) -> PairStatistics:
        """The fields of a summary.json document."""
        values = {one.name: document[one.name] for one in fields(cls)}
        return cls(
            **{
                name: Stats(**value) if isinstance(value, dict) else value
                for name, value in values.items()
            }
            | {
                "obstructing_flss_histogram": tuple(values["obstructing_flss_histogram"]),
                "quantiles": "exact" if values["quantiles"] == "exact" else "sketched",
            }
        )


@dataclass(frozen=True)
class Source:
    """Where a run's swarm came from: its cloud, the seed of its removals, its sensor file."""

    cloud: str
    cloud_source: str
    scale: float
    seed: int
    sensor_file: str
    # A resampled cloud's original and the resampling (summary.json's resampled_from).
    resampled: Resampled | None = None

    @classmethod
    def of(cls, cloud: Cloud, seed: int, sensor_file: str | Path | None) -> Source:
        """The source of a swarm made of ``cloud`` with ``seed``, its sensor read from
        ``sensor_file`` (None: the default, config/sensor.yaml)."""
        return cls(
            cloud.name,
            cloud.source,
            cloud.scale,
            seed,
            str(sensor_file or "config/sensor.yaml"),
            cloud.resampled,
        )

    def as_document(self) -> Document:
        """Its fields as summary.json's parameters hold them; ``resampled_from`` only
        for a resampled cloud."""
        document = _documents(self)
        resampled = document.pop("resampled")
        if resampled is not None:
            document["resampled_from"] = _documents(resampled)
        return document

    @classmethod
    def from_document(cls, document: Document) -> Source:
        """The source that summary.json's parameters hold (KeyError if none)."""
        named = {one.name: document[one.name] for one in fields(cls) if one.name != "resampled"}
        resampled = document.get("resampled_from")
        return cls(**named, resampled=None if resampled is None else Resampled(**resampled))


@dataclass(frozen=True)
class Parameters:
    """What a run was asked for; a heuristic's, fusion's and fit's are in their facts."""

    policy: str
    beta: float | None
    radius: float
    sensor: Document  # the sensor as its YAML file holds it (core.sensor)
    accurate: bool
    source: Source | None = None


@dataclass(frozen=True)
class HeuristicFacts:
    """A heuristic's summary (section 6): tried, resolved and move distances, cm.

    ``moved_distance`` is per move, of the resolved pairs only; the moves of
    pairs that were tried and still failed are ``failed_moved_distance``.
    ``moved_per_resolved_pair`` is what each resolved pair moved in all (the
    published Table 3's metric). Move Source adds ``flown_distance`` and
    ``displacement``.
    """

    technique: str
    threshold: int | None
    tried_pairs: int
    resolved_pairs: int
    moved_distance: Stats
    failed_moved_distance: Stats
    moved_per_resolved_pair: Stats
    compat: tuple[str, ...]
    flown_distance: Stats | None = None
    displacement: Stats | None = None
    # Move Source with --source-body: True; None (not in summary.json) for the spec's rule.
    source_body: bool | None = None

    @classmethod
    def from_document(cls, document: Document) -> HeuristicFacts:
        """The heuristic's fields of a summary.json document."""
        return cls(
            technique=document["technique"],
            threshold=document["threshold"],
            tried_pairs=document["tried_pairs"],
            resolved_pairs=document["resolved_pairs"],
            moved_distance=Stats(**document["moved_distance"]),
            failed_moved_distance=Stats(**document["failed_moved_distance"]),
            moved_per_resolved_pair=Stats(**document["moved_per_resolved_pair"]),
            compat=tuple(document["compat"]),
            flown_distance=_stats(document.get("flown_distance")),
            displacement=_stats(document.get("displacement")),
            source_body=document.get("source_body"),
        )


@dataclass(frozen=True)
class FusionFacts:
    """Fusion of up to ``paths`` paths per sweet pair: the pairs fused and their errors, %."""

    paths: int
    pairs_fused: int
    paths_per_pair: tuple[int, ...]  # sweet pairs by number of paths fused (index = number)
    distance_error_pct_one_path: Stats
    distance_error_pct_fused: Stats
    seconds: float

    @classmethod
    def from_document(cls, document: Document) -> FusionFacts:
        """The ``fusion`` object of a summary.json document."""
        return cls(
            paths=document["paths"],
            pairs_fused=document["pairs_fused"],
            paths_per_pair=tuple(document["paths_per_pair"]),
            distance_error_pct_one_path=Stats(**document["distance_error_pct_one_path"]),
            distance_error_pct_fused=Stats(**document["distance_error_pct_fused"]),
            seconds=document["seconds"],
        )


@dataclass(frozen=True)
class Consistency:
    """How honest a fit's covariances are: NEES, and how often it is within chi2 95 %."""

    nees: Stats
    within_chi2_95_pct: float


@dataclass(frozen=True)
class FitFacts:
    """A least-squares ``estimator``'s fit (core.fit); the swarm's own fits give only
    its consistency. Window facts for local-least-squares, iterations for swarm-fit."""

    estimator: str
    consistency: Consistency
    window_flss: Stats | None = None
    window_ms: Stats | None = None
    path_fallback_pairs: int | None = None
    iterations: tuple[tuple[int, ...], ...] | None = None
    robust: bool | None = None
    measurements: int | None = None
    downweighted: int | None = None
    seconds: float | None = None

    def as_document(self) -> Document:
        """The ``fit`` object of summary.json (its estimator is beside it)."""
        document = _documents(self, omit_none=True)
        del document["estimator"], document["consistency"]
        seconds = document.pop("seconds", None)
        document |= _documents(self.consistency)
        if seconds is not None:
            document["seconds"] = seconds
        return document

    @classmethod
    def from_document(cls, estimator: str, document: Document) -> FitFacts:
        """The ``fit`` object of a summary.json document, made by ``estimator``."""
        iterations = document.get("iterations")
        return cls(
            estimator=estimator,
            consistency=Consistency(Stats(**document["nees"]), document["within_chi2_95_pct"]),
            window_flss=_stats(document.get("window_flss")),
            window_ms=_stats(document.get("window_ms")),
            path_fallback_pairs=document.get("path_fallback_pairs"),
            iterations=None if iterations is None else tuple(tuple(one) for one in iterations),
            robust=document.get("robust"),
            measurements=document.get("measurements"),
            downweighted=document.get("downweighted"),
            seconds=document.get("seconds"),
        )


@dataclass(frozen=True)
class StudyRun:
    """A study's run (study.sweep): its cache key, its folder, and the pairs columns kept."""

    key: str
    run: str
    pairs: str


@dataclass(frozen=True)
class Summary:
    """A run's metrics (spec, section 6): the swarm, its pairs, what was asked, and the
    facts of a heuristic, fusion or fit when one made the run. ``seconds``: the run's
    computation, s (None for a swarm's discovery until the run's time is known)."""

    flss: int
    cloud_points: int
    removed: int
    radius: float
    dmin: float
    beta: float | None
    kissing_pairs: int
    sweet_neighbour_pairs: int
    decaying_neighbour_pairs: int
    pairs: PairStatistics
    parameters: Parameters
    version: str
    seconds: float | None = None
    heuristic: HeuristicFacts | None = None
    fusion: FusionFacts | None = None
    fit: FitFacts | None = None
    study: StudyRun | None = None

    def as_document(self) -> Document:
        """Exactly what summary.json holds: its keys, their order and values."""
        document = {
            **{name: getattr(self, name) for name in _SWARM_FIELDS},
            **self.pairs.as_document(),
            "parameters": self._parameters_document(),
            "version": self.version,
            "seconds": self.seconds,
        }
        if self.heuristic is not None:
            facts = _documents(self.heuristic)
            # Move Source's two more statistics; a threshold is there even when None.
            document |= {
                key: value
                for key, value in facts.items()
                if value is not None or key == "threshold"
            }
        if self.fusion is not None:
            document["fusion"] = _documents(self.fusion)
        if self.fit is not None:
            document["estimator"] = self.fit.estimator
            document["fit"] = self.fit.as_document()
        if self.study is not None:
            document["study"] = _documents(self.study)
        return document

    def _parameters_document(self) -> Document:
        asked = self.parameters
        document: Document = {
            "policy": asked.policy,
            "beta": asked.beta,
            "radius": asked.radius,
            "sensor": asked.sensor,
            "accurate": asked.accurate,
        }
        if self.heuristic is not None:
            document["technique"] = self.heuristic.technique
            document["threshold"] = self.heuristic.threshold
            if self.heuristic.source_body:
                document["source_body"] = True
        if self.fusion is not None:
            document["fuse"] = self.fusion.paths
        if self.fit is not None:
            document["estimator"] = self.fit.estimator
        if asked.source is not None:
            document |= asked.source.as_document()
        return document

    @classmethod
    def from_document(cls, document: Document) -> Summary:
        """The summary a summary.json document holds (KeyError or TypeError if it is not one)."""
        asked = document["parameters"]
        source = None
        if "cloud" in asked:
            source = Source.from_document(asked)
        parameters = Parameters(
            asked["policy"], asked["beta"], asked["radius"], asked["sensor"], asked["accurate"],
            source,
        )  # fmt: skip
        fit = document.get("fit")
        return cls(
            **{name: document[name] for name in _SWARM_FIELDS},
            pairs=PairStatistics.from_document(document),
            parameters=parameters,
            version=document["version"],
            seconds=document.get("seconds"),
            heuristic=HeuristicFacts.from_document(document)
            if "tried_pairs" in document
            else None,
            fusion=FusionFacts.from_document(document["fusion"]) if "fusion" in document else None,
            fit=None if fit is None else FitFacts.from_document(document["estimator"], fit),
            study=StudyRun(**document["study"]) if "study" in document else None,
        )


_SWARM_FIELDS = (
    "flss", "cloud_points", "removed", "radius", "dmin", "beta",
    "kissing_pairs", "sweet_neighbour_pairs", "decaying_neighbour_pairs",
)  # fmt: skip


def with_source(
    summary: Summary, cloud: Cloud, seed: int, sensor_file: str | Path | None
) -> Summary:
    """``summary`` with where the run's swarm came from in its parameters: a new summary.

    Parameters
    ----------
    summary : Summary
    cloud : Cloud
        The cloud the swarm was made of: its name, file and scale.
    seed : int
        The collision removal's seed.
    sensor_file : str or Path, optional
        The sensor's file; ``config/sensor.yaml`` when None or empty.

    Returns
    -------
    Summary
        A copy whose ``parameters.source`` says all that.
    """
    source = Source.of(cloud, seed, sensor_file)
    return replace(summary, parameters=replace(summary.parameters, source=source))
