"""The pairs by class in a comparison (``swazure compare``): each run's results, the verdicts.

For each class of pairs (:data:`PAIR_CLASSES`), each run's coverage (the
share of the class's pairs it estimates) and its median and mean error over
those (:func:`class_results`), and which run is better by each
(:func:`class_verdict`).

A pair's class is its ``reason`` in the per-pair table, which no heuristic
and no estimator changes: every run of one swarm is judged on the same pairs
in each class, though a heuristic moves some of them to a sweet path.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .metric_rows import Better, rank

#: The error a comparison ranks pairs by: the position error |estimate - truth| in cm,
#: or, when a run's per-pair file leaves out the truth (the study's compact files), the
#: distance error in % that every per-pair file keeps.
ErrorUnit = Literal["cm", "%"]
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
    >>> from swazure_ros.core.pair_classes import PairErrors, class_results
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
