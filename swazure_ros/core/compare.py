"""Runs compared side by side (``swazure compare``): their summaries, and who did better where.

Two kinds of comparison, both as frozen records:

- the summaries' numbers (:data:`.metric_rows.METRICS`), one row each with
  every run's value, its difference from the first run's, and the runs with
  the best value where "better" has a direction (:mod:`.metric_rows`);
- the pairs by class (:data:`.pair_classes.PAIR_CLASSES`): for each class,
  each run's coverage and its median and mean error, and which run is better
  by each (:mod:`.pair_classes`).

Here: a run in a comparison, its rows by class of pairs, and
:func:`compare`, which puts two or more runs of one cloud side by side.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from .errors import SwazureError
from .metric_rows import METRICS, MetricRow, metric_row, row_of_values
from .pair_classes import (
    PAIR_CLASSES,
    ClassResult,
    ClassVerdict,
    ErrorUnit,
    PairErrors,
    class_results,
    class_verdict,
)
from .summary import Summary


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
            rows.append(row_of_values(f"{name}: {label}", better, values, why))  # type: ignore[arg-type]
    return tuple(rows)


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
