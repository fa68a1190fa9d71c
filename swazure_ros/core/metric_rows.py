"""The summaries' numbers side by side (``swazure compare``): one row each, who did better.

Each of :data:`METRICS` is a number of a run's summary; its row
(:class:`MetricRow`) holds every run's value, its difference from the first
run's, and the runs with the best value where "better" has a direction (a
smaller error, a larger share of sweet paths), ties within :data:`TIE`
grouped (:func:`rank`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from .metrics import Stats
from .summary import Summary

#: Which way a number is better: "lower" (an error), "higher" (a share of sweet paths),
#: or "neither" (what the run is: its pairs, its hops).
Better = Literal["lower", "higher", "neither"]
#: Two values within this relative difference are a tie: they agree to about the four
#: significant digits the table prints (least-squares and swarm-fit solve one fit to
#: about 1e-6 of each other).
TIE = 1e-4


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
    >>> from swazure_ros.core.metric_rows import rank
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
    return row_of_values(metric.label, metric.better, values, why)


def row_of_values(
    label: str, better: Better, values: Sequence[float | None], why_none: Sequence[str | None]
) -> MetricRow:
    """The row of ``values``: their deltas from the first, and the best if ``better`` says.

    Parameters
    ----------
    label : str
        The row's label.
    better : {'lower', 'higher', 'neither'}
    values : sequence of float or None
        One per run, the reference first; None for a run without the number.
    why_none : sequence of str or None
        Why each run has no value (None where it has one).

    Returns
    -------
    MetricRow
        The values, their deltas from the first, and the best runs and
        their margin where ``better`` has a direction.
    """
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
