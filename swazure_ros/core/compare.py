"""Runs compared side by side (``swazure compare``): their summaries, and who did better where.

Two kinds of comparison, both as frozen records:

- the summaries' numbers (:data:`METRICS`), one row each with every run's
  value, its difference from the first run's, and the runs with the best
  value where "better" has a direction (a smaller error, a larger share of
  sweet paths);
- the pairs by class (:data:`PAIR_CLASSES`): for each class, each run's
  coverage (the share of the class's pairs it estimates) and its median and
  mean error over those, and which run is better by each.

A pair's class is its ``reason`` in the per-pair table, which no heuristic
and no estimator changes: every run of one swarm is judged on the same pairs
in each class, though a heuristic moves some of them to a sweet path.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .errors import SwazureError
from .metrics import Stats
from .summary import Summary

#: Which way a number is better: "lower" (an error), "higher" (a share of sweet paths),
#: or "neither" (what the run is: its pairs, its hops).
Better = Literal["lower", "higher", "neither"]
#: The error a comparison ranks pairs by: the position error |estimate - truth| in cm,
#: or, when a run's per-pair file leaves out the truth (the study's compact files), the
#: distance error in % that every per-pair file keeps.
ErrorUnit = Literal["cm", "%"]
#: Two values within this relative difference are a tie: they agree to about the four
#: significant digits the table prints (least-squares and swarm-fit solve one fit to
#: about 1e-6 of each other).
TIE = 1e-4
#: The pairs' classes: every pair, then a pair's ``reason`` in the per-pair table
#: (core.evaluation.REASON_NAMES, in its order): a sweet path in sight; every sweet path
#: blocked by an FLS (a decaying path or none: the pairs a heuristic tries); the sweet
#: graph does not join them at all; a distributed run's pairs lost with their coordinator.
ALL_PAIRS = "all pairs"
PAIR_CLASSES = (ALL_PAIRS, "sweet path", "blocked", "no sweet path", "aborted")
#: The levels of the error distribution kept per run and class: its 0th to 100th
#: percentiles in steps of 0.5 (the figure's curves).
CDF_LEVELS = np.linspace(0.0, 1.0, 201)


@dataclass(frozen=True)
class Metric:
    """A number of a run's summary: its label (as the summary's rows name it), which way
    is better, how it is read from a :class:`Summary` (None when the run has none), and
    why a run has none (the summary's rows say "-" only with a reason; so does a
    comparison)."""

    label: str
    better: Better
    value: Callable[[Summary], float | None]
    why_none: Callable[[Summary], str] = lambda summary: "no pair has a path"


def _of(stats: Callable[[Summary], Stats | None], field: str) -> Callable[[Summary], float | None]:
    def value(summary: Summary) -> float | None:
        found = stats(summary)
        return None if found is None else getattr(found, field)

    return value


def _pair_stat(name: str, field: str) -> Callable[[Summary], float | None]:
    """A statistic of the summary's pairs: ``field`` of ``PairStatistics.<name>``."""
    return _of(lambda summary: getattr(summary.pairs, name), field)


def _heuristic(name: str) -> Callable[[Summary], Any]:
    """A field of the summary's heuristic facts (None for a run without a heuristic)."""
    return lambda summary: None if summary.heuristic is None else getattr(summary.heuristic, name)


def _noise_model(summary: Summary) -> bool:
    """Whether a fit's predicted errors are a spread: under the published model the error
    is one bias, not a spread, so a fit's covariance and NEES mean nothing there (the
    summary shows "- (no noise model)", docs/core.md)."""
    return summary.fit is None or summary.parameters.sensor["error_model"]["kind"] == "stochastic"


def _predicted(value: Callable[[Summary], float | None]) -> Callable[[Summary], float | None]:
    """A predicted-error number, None for a fit without a noise model."""
    return lambda summary: value(summary) if _noise_model(summary) else None


def _why_no_prediction(summary: Summary) -> str:
    return "no noise model" if not _noise_model(summary) else "no pair has a path"


def _nees(summary: Summary) -> float | None:
    return summary.fit.consistency.nees.mean if summary.fit and _noise_model(summary) else None


def _why_no_nees(summary: Summary) -> str:
    return "no fit in this run" if summary.fit is None else "no noise model"


def _why_no_heuristic(summary: Summary) -> str:
    return "no heuristic in this run" if summary.heuristic is None else "no pair resolved"


#: The summary's numbers a comparison puts side by side, in the order of the summary's rows.
METRICS: tuple[Metric, ...] = (
    Metric("FLSs", "neither", lambda s: s.flss),
    Metric("ordered blind pairs", "neither", lambda s: s.pairs.blind_pairs),
    Metric("sweet path, %", "higher", lambda s: s.pairs.sweet_pct),
    Metric("decaying path, %", "neither", lambda s: s.pairs.decaying_pct),
    Metric("no path, %", "lower", lambda s: s.pairs.no_path_pct),
    Metric("blocked pairs", "neither", lambda s: s.pairs.blocked_pairs),
    Metric("no sweet path pairs", "neither", lambda s: s.pairs.no_sweet_path_pairs),
    Metric("obstructed sweet paths, %", "neither", lambda s: s.pairs.obstructed_path_pct),
    Metric(
        "predicted error, cm: mean",
        "neither",
        _predicted(_pair_stat("predicted_error_cm", "mean")),
        _why_no_prediction,
    ),
    Metric(
        "within predicted error, %",
        "neither",
        _predicted(lambda s: s.pairs.within_predicted_pct),
        _why_no_prediction,
    ),
    Metric("NEES: mean", "neither", _nees, _why_no_nees),
    Metric("tried pairs", "neither", _heuristic("tried_pairs"), _why_no_heuristic),
    Metric("resolved pairs", "higher", _heuristic("resolved_pairs"), _why_no_heuristic),
    Metric(
        "moved per resolved pair, cm: mean",
        "lower",
        _of(_heuristic("moved_per_resolved_pair"), "mean"),
        _why_no_heuristic,
    ),
    Metric("distance error, %: mean", "lower", _pair_stat("distance_error_pct", "mean")),
    Metric("distance error, %: median", "lower", _pair_stat("distance_error_pct", "p50")),
    Metric("distance error, %: max", "lower", _pair_stat("distance_error_pct", "max")),
    Metric(
        "sweet error, %: mean",
        "lower",
        _pair_stat("distance_error_pct_sweet_paths", "mean"),
        lambda s: "no sweet path",
    ),
    Metric(
        "decaying error, %: mean",
        "lower",
        _pair_stat("distance_error_pct_decaying_paths", "mean"),
        lambda s: "no decaying path",
    ),
    Metric("alpha, deg: mean", "lower", _pair_stat("alpha_deg", "mean")),
    Metric("theta error, deg: mean", "lower", _pair_stat("theta_deg", "mean")),
    Metric("phi error, deg: mean", "lower", _pair_stat("phi_deg", "mean")),
    Metric("hops: mean", "neither", _pair_stat("hops", "mean")),
    Metric("seconds", "lower", lambda s: s.seconds),
)  # fmt: skip


@dataclass(frozen=True)
class MetricRow:
    """One number of every run's summary. ``deltas``: each value minus the first run's;
    ``best``: the runs (indices) with the best value, empty when "better" has no
    direction, fewer than two runs have the number, or all of them tie; ``margin``: the
    best value minus the next best, signed (None without a best)."""

    label: str
    better: Better
    values: tuple[float | None, ...]
    deltas: tuple[float | None, ...]
    best: tuple[int, ...]
    margin: float | None
    # Why each run has no value (None where it has one): a "-" is shown with its reason.
    why_none: tuple[str | None, ...] = ()


@dataclass(frozen=True)
class PairErrors:
    """What a comparison needs of a run's per-pair table: each pair's class (an index of
    ``PAIR_CLASSES[1:]``, its reason code) and its error in ``unit`` (NaN: no estimate)."""

    pair_class: NDArray[np.uint8]
    error: NDArray[np.float64]
    unit: ErrorUnit


@dataclass(frozen=True)
class ClassResult:
    """One run on one class of pairs: its pairs, those it estimates, and their errors.

    ``coverage_pct``: estimated / pairs in % (None without pairs); ``median`` and
    ``mean``: of the estimated pairs' errors, in the comparison's unit (None without
    one); ``cdf``: their quantiles at :data:`CDF_LEVELS` (empty without one).
    """

    pair_class: str
    pairs: int
    estimated: int
    coverage_pct: float | None
    median: float | None
    mean: float | None
    cdf: tuple[float, ...]


@dataclass(frozen=True)
class ClassVerdict:
    """Which runs did better on a class: by median error (lower) and by coverage (higher).

    ``by_median`` and ``by_coverage`` are the runs (indices) in rank order, tied runs
    grouped: ``((2, 3), (0,), (1,))`` is runs 2 and 3 tied first, then 0, then 1. A run
    that estimates none of the class's pairs is not ranked by error. ``statement`` says
    it in one line.
    """

    pair_class: str
    by_median: tuple[tuple[int, ...], ...]
    by_coverage: tuple[tuple[int, ...], ...]
    statement: str


@dataclass(frozen=True)
class ComparedRun:
    """A run in a comparison: its label, what it ran, its summary, and its results by class
    of pairs (in :data:`PAIR_CLASSES` order; None when it has no per-pair table)."""

    label: str
    method: str
    summary: Summary
    classes: tuple[ClassResult, ...] | None


@dataclass(frozen=True)
class Comparison:
    """Two or more runs side by side: the runs, their summaries' rows, their rows by class
    of pairs, the error's unit and the verdicts by class of pairs (for the runs with a
    per-pair table)."""

    runs: tuple[ComparedRun, ...]
    rows: tuple[MetricRow, ...]
    class_rows: tuple[MetricRow, ...]
    error_unit: ErrorUnit
    verdicts: tuple[ClassVerdict, ...]


def method(summary: Summary) -> str:
    """What a run ran, in a few words.

    Parameters
    ----------
    summary : Summary

    Returns
    -------
    str
        ``plain``, a heuristic (``move-source (T 10)`` with Move Source's
        threshold), a fit's estimator, or ``fused (K paths)``.
    """
    if summary.heuristic is not None:
        heuristic = summary.heuristic
        if heuristic.threshold is None:
            return heuristic.technique
        return f"{heuristic.technique} (T {heuristic.threshold})"
    if summary.fit is not None:
        return summary.fit.estimator
    if summary.fusion is not None:
        return f"fused ({summary.fusion.paths} paths)"
    return "plain"


def cloud_of(summary: Summary) -> str:
    """The name of a run's cloud, or its points and FLSs when its summary names no source.

    Parameters
    ----------
    summary : Summary

    Returns
    -------
    str
        The cloud's name; ``"N points, M FLSs"`` for a summary without a
        source in its parameters (an older summary, or one made in Python).
    """
    source = summary.parameters.source
    if source is not None:
        return source.cloud
    return f"{summary.cloud_points} points, {summary.flss} FLSs"


def _number(value: object) -> float | None:
    """A summary's number as a float; None for a missing one (None or NaN in the file)."""
    if value is None:
        return None
    number = float(value)  # type: ignore[arg-type]
    return number if math.isfinite(number) else None


def _ties(a: float, b: float) -> bool:
    return abs(a - b) <= TIE * max(abs(a), abs(b))


def rank(values: Sequence[float | None], better: Better) -> tuple[tuple[int, ...], ...]:
    """The runs (indices) with a value, best first, tied runs (within :data:`TIE`) grouped.

    Ties are grouped by their distance to the group's first value, so a group never
    drifts; a group lists its runs in their order.

    Parameters
    ----------
    values : sequence of float or None
        One per run; None for a run without the number.
    better : {'lower', 'higher'}

    Returns
    -------
    tuple of tuple of int
        Groups of run indices, best group first; runs without a value left out.

    Raises
    ------
    ValueError
        ``better`` is ``'neither'``.

    Examples
    --------
    >>> from swazure_ros.core.compare import rank
    >>> rank([0.5, None, 0.2, 0.20000001], "lower")  # runs 2 and 3 tie within TIE
    ((2, 3), (0,))
    """
    if better == "neither":
        raise ValueError("better must be 'lower' or 'higher' to rank, got 'neither'")
    sign = 1.0 if better == "lower" else -1.0
    known = sorted(
        (sign * value, index) for index, value in enumerate(values) if value is not None
    )
    groups: list[list[int]] = []
    first = 0.0
    for key, index in known:
        if groups and _ties(key, first):
            groups[-1].append(index)
        else:
            groups.append([index])
            first = key
    return tuple(tuple(sorted(group)) for group in groups)


def metric_row(metric: Metric, summaries: Sequence[Summary]) -> MetricRow:
    """One :class:`MetricRow` of ``summaries`` (the first is the reference of the deltas).

    Parameters
    ----------
    metric : Metric
        One of :data:`METRICS`.
    summaries : sequence of Summary
        The runs, the reference first.

    Returns
    -------
    MetricRow
        Each run's value (None with its reason), its difference from the
        first's, and the best runs where the metric has a direction.
    """
    values = [_number(metric.value(s)) for s in summaries]
    why = [
        None if value is not None else metric.why_none(s)
        for value, s in zip(values, summaries, strict=True)
    ]
    return _row(metric.label, metric.better, values, why)


def _row(
    label: str, better: Better, values: Sequence[float | None], why_none: Sequence[str | None]
) -> MetricRow:
    """The row of ``values``: their deltas from the first, and the best if ``better`` says."""
    reference = values[0]
    deltas = tuple(
        None if value is None or reference is None else value - reference for value in values
    )
    best: tuple[int, ...] = ()
    margin = None
    if better != "neither":
        ranks = rank(values, better)
        if len(ranks) > 1:
            best = ranks[0]
            top, runner_up = values[best[0]], values[ranks[1][0]]
            assert top is not None and runner_up is not None  # ranked runs have values
            margin = top - runner_up
    return MetricRow(label, better, tuple(values), deltas, best, margin, tuple(why_none))


def class_rows(runs: Sequence[ComparedRun], unit: ErrorUnit) -> tuple[MetricRow, ...]:
    """Rows of the runs' results by class of pairs: each class's coverage, median and mean error.

    Parameters
    ----------
    runs : sequence of ComparedRun
    unit : {'cm', '%'}
        The errors' unit, for the rows' labels.

    Returns
    -------
    tuple of MetricRow
        Three rows per class that some run has pairs of; a run without a
        per-pair table shows None, with its reason.
    """
    rows = []
    for code, name in enumerate(PAIR_CLASSES):
        results = [None if run.classes is None else run.classes[code] for run in runs]
        if not any(result is not None and result.pairs for result in results):
            continue
        for label, better, field in (
            ("coverage, %", "higher", "coverage_pct"),
            (f"median error, {unit}", "lower", "median"),
            (f"mean error, {unit}", "lower", "mean"),
        ):
            values = [None if result is None else getattr(result, field) for result in results]
            why = [
                None
                if value is not None
                else ("no per-pair file" if result is None else "no pair of the class estimated")
                for value, result in zip(values, results, strict=True)
            ]
            rows.append(_row(f"{name}: {label}", better, values, why))  # type: ignore[arg-type]
    return tuple(rows)


def class_results(errors: PairErrors) -> tuple[ClassResult, ...]:
    """A run's :class:`ClassResult` for each of :data:`PAIR_CLASSES`, all pairs first.

    Parameters
    ----------
    errors : PairErrors
        Each pair's class (its reason code) and error (NaN: no estimate).

    Returns
    -------
    tuple of ClassResult
        One per class, in :data:`PAIR_CLASSES` order: pairs, estimated
        pairs, coverage (%), median and mean error (in ``errors.unit``) and
        the error's quantiles.

    Raises
    ------
    ValueError
        ``pair_class`` and ``error`` are not of one shape (N,).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.compare import PairErrors, class_results
    >>> errors = PairErrors(np.array([0, 0, 1, 1], dtype=np.uint8),
    ...                     np.array([0.1, 0.3, np.nan, 2.0]), "cm")
    >>> [(r.pair_class, r.pairs, r.coverage_pct, r.median) for r in class_results(errors)[:3]]
    [('all pairs', 4, 75.0, 0.3), ('sweet path', 2, 100.0, 0.2), ('blocked', 2, 50.0, 2.0)]
    """
    pair_class = np.asarray(errors.pair_class)
    error = np.asarray(errors.error, dtype=np.float64)
    if pair_class.shape != error.shape or error.ndim != 1:
        raise ValueError(
            f"Expected pair_class and error of one shape (N,), got {pair_class.shape} "
            f"and {error.shape}"
        )
    results = []
    for code, name in enumerate(PAIR_CLASSES):
        members = np.ones(len(error), bool) if name == ALL_PAIRS else pair_class == code - 1
        found = error[members]
        found = found[np.isfinite(found)]
        pairs, estimated = int(members.sum()), len(found)
        results.append(
            ClassResult(
                name,
                pairs,
                estimated,
                100.0 * estimated / pairs if pairs else None,
                float(np.median(found)) if estimated else None,
                float(found.mean()) if estimated else None,
                tuple(float(q) for q in np.quantile(found, CDF_LEVELS)) if estimated else (),
            )
        )
    return tuple(results)


def _figure(value: float) -> str:
    return f"{value:.4g}"


def _ranking(
    labels: Sequence[str],
    values: Sequence[float | None],
    ranks: tuple[tuple[int, ...], ...],
    better: Better,
    unit: str,
) -> str:
    """``a 0.1 = b 0.1 < c 0.3 cm``: the ranked runs and their values, best first."""
    if len(ranks) == 1 and len(ranks[0]) == len(labels) > 1:
        return f"all {_figure(values[ranks[0][0]] or 0.0)} {unit}"
    step = " < " if better == "lower" else " > "
    groups = [" = ".join(f"{labels[i]} {_figure(values[i] or 0.0)}" for i in g) for g in ranks]
    return f"{step.join(groups)} {unit}"


def class_verdict(
    labels: Sequence[str], results: Sequence[ClassResult | None], unit: ErrorUnit
) -> ClassVerdict:
    """Which of the runs did better on one class of pairs: by median error and by coverage.

    Parameters
    ----------
    labels : sequence of str
        The runs' labels.
    results : sequence of ClassResult or None
        Run i's result on the class; None: run i has no per-pair table and is
        not judged. At least one is not None.
    unit : {'cm', '%'}

    Returns
    -------
    ClassVerdict
        The rankings and a one-line statement of them.
    """
    name = next(result.pair_class for result in results if result is not None)
    medians = [None if r is None else r.median for r in results]
    coverages = [None if r is None else r.coverage_pct for r in results]
    by_median, by_coverage = rank(medians, "lower"), rank(coverages, "higher")
    counts = {labels[i]: result.pairs for i, result in enumerate(results) if result}
    if len(set(counts.values())) == 1:
        pairs = f"{next(iter(counts.values())):,} pairs"
    else:
        # Runs of one cloud with another beta, sensor or seed: classes of other sizes.
        pairs = "pairs: " + ", ".join(f"{label} {count:,}" for label, count in counts.items())
    if not by_median:
        errors = "no run estimates any"
    else:
        errors = "by median error " + _ranking(labels, medians, by_median, "lower", unit)
        none = [labels[i] for i, r in enumerate(results) if r is not None and r.median is None]
        if none:
            errors += f" ({', '.join(none)}: none estimated)"
    coverage = "by coverage " + _ranking(labels, coverages, by_coverage, "higher", "%")
    return ClassVerdict(name, by_median, by_coverage, f"{name} ({pairs}): {errors}; {coverage}")


def check_one_cloud(labels: Sequence[str], summaries: Sequence[Summary]) -> None:
    """SwazureError in one line unless every run is of one cloud.

    The pairs of two clouds are not the same pairs, and no row or class of
    theirs compares.

    Parameters
    ----------
    labels : sequence of str
        The runs' labels, for the message.
    summaries : sequence of Summary

    Raises
    ------
    SwazureError
        Runs of different clouds (:func:`cloud_of`), each named.
    """
    clouds = [cloud_of(summary) for summary in summaries]
    if len(set(clouds)) > 1:
        runs = ", ".join(f"{label} ({cloud})" for label, cloud in zip(labels, clouds, strict=True))
        raise SwazureError(f"runs of different clouds: {runs}; compare runs of one cloud")


def compare(runs: Sequence[tuple[str, Summary, PairErrors | None]]) -> Comparison:
    """Two or more runs of one cloud side by side, the first the reference of the deltas.

    Parameters
    ----------
    runs : sequence of (str, Summary, PairErrors or None)
        Each run's label, summary and per-pair errors (None without a
        per-pair table: the run is then not judged by class of pairs).

    Returns
    -------
    Comparison
        The summaries' rows (those some run has), the rows and verdicts by
        class of pairs, and the errors' unit.

    Raises
    ------
    SwazureError
        Fewer than two runs, two runs of one label, runs of different clouds.
    ValueError
        Per-pair errors in different units.

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points
    >>> from swazure_ros.core.compare import compare
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(builtin_points("torus:120") * 5, beta=0.5)
    >>> runs = [(policy, evaluate(swarm, published, policy).summary, None)
    ...         for policy in ("shortest-length", "fewest-hops")]
    >>> row = next(row for row in compare(runs).rows if row.label == "hops: mean")
    >>> row.deltas, row.best  # on this torus both policies take the same paths: a tie
    ((0.0, 0.0), ())
    """
    labels = [label for label, _, _ in runs]
    summaries = [summary for _, summary, _ in runs]
    if len(runs) < 2:
        raise SwazureError(f"compare needs two or more runs, got {len(runs)}")
    twice = sorted({label for label in labels if labels.count(label) > 1})
    if twice:
        raise SwazureError(f"runs given twice: {', '.join(twice)}")
    check_one_cloud(labels, summaries)
    units = {errors.unit for _, _, errors in runs if errors is not None}
    if len(units) > 1:
        raise ValueError(f"Expected the runs' errors in one unit, got {sorted(units)}")
    rows = tuple(
        row
        for row in (metric_row(metric, summaries) for metric in METRICS)
        if any(value is not None for value in row.values)
    )
    compared = tuple(
        ComparedRun(
            label,
            method(summary),
            summary,
            None if errors is None else class_results(errors),
        )
        for label, summary, errors in runs
    )
    unit: ErrorUnit = units.pop() if units else "cm"
    verdicts: list[ClassVerdict] = []
    if sum(run.classes is not None for run in compared) > 1:
        for code, _ in enumerate(PAIR_CLASSES):
            results = [None if run.classes is None else run.classes[code] for run in compared]
            if any(result is not None and result.pairs for result in results):
                verdicts.append(class_verdict(labels, results, unit))
    return Comparison(compared, rows, class_rows(compared, unit), unit, tuple(verdicts))
