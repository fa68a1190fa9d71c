"""Least-squares localization: an evaluation's estimates from a fit of the swarm's measurements.

A path's estimate sums the measured vectors of one chain of hops and
carries every error of that chain. The swarm measures far more: every
visible sweet pair, from both ends. A least-squares fit over that
measurement graph (:mod:`.least_squares`) estimates every pair at once,
with a covariance. :func:`refine` gives an evaluation the estimates of one
of the :data:`ESTIMATORS`, the fit of the whole swarm or each source's
own (:mod:`.pair_fits`), with their consistency (:func:`consistency`).
docs/core.md ("The least-squares fit") derives the weights, the gauge, how
decaying hops join the sweet parts and the robust loss.
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from .arrays import FloatArray
from .errors import SwazureError
from .evaluation import NO_PATH, SWEET_PATH, Evaluation, PairResults
from .fit_measurements import Corruption
from .geometry import tracking_distance
from .heuristics.result import PLAIN
from .hop_errors import hop_covariance, measured_vectors, unbiased_vectors
from .metrics import Stats, describe
from .neighbourhood import Neighbourhood
from .pair_fits import PairFit, WholeFits, local_estimates
from .pair_statistics import EXACT_VALUES, summarise
from .path_arrays import Paths, path_hops
from .progress import SILENT, Progress
from .summary import Consistency, FitFacts
from .tally import RealTally

#: The estimators of a pair's pose: the paper's sum along the policy's path; the fit over
#: the whole swarm's measurements; each source's own fit over what it hears by radio; the
#: same fit as the first, solved by the swarm's messages with measured neighbours only.
PATH, LEAST_SQUARES, LOCAL_LEAST_SQUARES = "path", "least-squares", "local-least-squares"
SWARM_FIT = "swarm-fit"
ESTIMATORS = (PATH, LEAST_SQUARES, LOCAL_LEAST_SQUARES, SWARM_FIT)
#: The fits of the whole swarm, read off one solve pair by pair: a run of them is made in
#: blocks (:class:`WholeFitEstimates`). Each source's own fit lays out its window from
#: every FLS's radio neighbours, the blind pairs a neighbourhood made in blocks does not hold.
BLOCKED_ESTIMATORS = (LEAST_SQUARES, SWARM_FIT)


def check_plain_estimator(estimator: str, technique: str = PLAIN, fuse: int = 1) -> None:
    """Check that a fit is asked of plain Swazure's pairs alone.

    Parameters
    ----------
    estimator : str
        One of :data:`ESTIMATORS`.
    technique : str, optional
        The heuristic run on blocked pairs (``core.heuristics.result.TECHNIQUES``).
    fuse : int, optional
        The paths fused per pair.

    Raises
    ------
    SwazureError
        A fit with fused paths or a heuristic's moves; the message names the
        options (``--fuse``, ``--technique``) to leave out.

    Examples
    --------
    >>> check_plain_estimator("least-squares", fuse=3)
    Traceback (most recent call last):
    ...
    swazure_ros.core.errors.SwazureError: --estimator least-squares ...: leave out --fuse
    """
    if estimator == PATH:
        return
    asked = [
        name
        for name, given in (("--fuse", fuse > 1), ("--technique", technique != PLAIN))
        if given
    ]
    if asked:
        raise SwazureError(
            f"--estimator {estimator} estimates plain Swazure's pairs: "
            f"leave out {' and '.join(asked)}"
        )


#: What a swarm's sources run: a source fits what it hears, never the whole swarm at once.
SWARM_ESTIMATORS = (PATH, LOCAL_LEAST_SQUARES, SWARM_FIT)
#: The chi-square bound that 95 % of 3-D errors fall under, when the covariance is right.
CHI2_95_3DOF = 7.8147


def path_estimates(hood: Neighbourhood, pairs: PairResults) -> tuple[FloatArray, FloatArray]:
    """Each pair's path sum with the sensor's known bias removed, and its covariance.

    What a source whose window does not reach its target falls back on: the
    measured hops of the policy's path, each without the sensor's known bias
    (:func:`~.hop_errors.unbiased_vectors`), and the sum of their covariances
    (independent hops).

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    pairs : PairResults
        M pairs and their paths.

    Returns
    -------
    estimate : (M, 3) ndarray of float, cm
        NaN without a path.
    covariance : (M, 3, 3) ndarray of float, cm^2
        NaN without a path.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> run = evaluate(swarm, sensor, "shortest-length")
    >>> estimate, covariance = path_estimates(run.hood, run.pairs)
    >>> estimate.shape, covariance.shape, bool(np.isfinite(covariance).all())
    ((2, 3), (2, 3, 3), True)
    """
    swarm, sensor = hood.swarm, hood.sensor
    paths = Paths(pairs.status != NO_PATH, pairs.hops, pairs.path_length, pairs.offsets,
                  pairs.nodes)  # fmt: skip
    owner, start, end = path_hops(paths)
    raw = measured_vectors(sensor, swarm.points, swarm.radius, start, end)
    tracking = tracking_distance(swarm.points, swarm.radius, start, end)
    directions = raw / np.linalg.norm(raw, axis=1, keepdims=True)
    vectors = unbiased_vectors(sensor, raw, tracking)
    hop_cov = hop_covariance(sensor, tracking, directions, swarm.radius)
    count = len(pairs)
    estimate = np.zeros((count, 3))
    covariance = np.zeros((count, 3, 3))
    np.add.at(estimate, owner, vectors)
    np.add.at(covariance, owner, hop_cov)
    estimate[~paths.found] = np.nan
    covariance[~paths.found] = np.nan
    return estimate, covariance


def normalized_errors(error: FloatArray, covariance: FloatArray) -> FloatArray:
    """The normalized estimation error squared (NEES) e^T C^-1 e of each estimate.

    Near 3 on average for 3-D errors whose covariance is honest.

    Parameters
    ----------
    error : (M, 3) ndarray of float, cm
        Each estimate less the truth.
    covariance : (M, 3, 3) ndarray of float, cm^2
        Each estimate's covariance.

    Returns
    -------
    (M,) ndarray of float
        NaN where the error or its covariance is unknown.

    Examples
    --------
    >>> import numpy as np
    >>> error = np.array([[0.2, 0.0, 0.0], [np.nan, 0, 0]])
    >>> normalized_errors(error, np.tile(0.01 * np.eye(3), (2, 1, 1))).round(9).tolist()
    [4.0, nan]
    """
    known = np.isfinite(error).all(axis=1) & np.isfinite(covariance).all(axis=(1, 2))
    out = np.full(len(error), np.nan)
    if known.any():
        solved = np.linalg.solve(covariance[known], error[known][:, :, None])[:, :, 0]
        out[known] = np.einsum("ma,ma->m", error[known], solved)
    return out


def consistency(pairs: PairResults) -> Consistency:
    """How honest the pairs' covariances are: their NEES, and how often it is within chi2 95 %.

    Parameters
    ----------
    pairs : PairResults
        Pairs with a covariance (a fit's, :func:`refine`).

    Returns
    -------
    Consistency
        The NEES's statistics (:func:`normalized_errors`) over the pairs
        with an estimate, and the share of them within :data:`CHI2_95_3DOF`, %.

    Raises
    ------
    ValueError
        The pairs' estimator gives no covariance (the path sum).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> run = evaluate(swarm, sensor, "shortest-length")
    >>> consistency(run.pairs)
    Traceback (most recent call last):
    ...
    ValueError: these pairs' estimator gives no covariance
    >>> fitted = refine(run)
    >>> consistency(fitted.pairs) == fitted.summary.fit.consistency
    True
    """
    if pairs.covariance is None:
        raise ValueError("these pairs' estimator gives no covariance")
    nees = normalized_errors(pairs.estimate - pairs.truth, pairs.covariance)
    known = np.isfinite(nees)
    return Consistency(
        nees=describe(nees[known]),
        within_chi2_95_pct=float(100.0 * (nees[known] <= CHI2_95_3DOF).mean())
        if known.any()
        else float("nan"),
    )


def refine(
    evaluation: Evaluation,
    estimator: str = LEAST_SQUARES,
    robust: bool = True,
    corrupt: Corruption | None = None,
) -> Evaluation:
    """An evaluation with every estimate from a least-squares estimator, and its covariance.

    Statuses, reasons and the reported paths stay the policy's; estimates,
    errors and predicted errors (the square root of the covariance's trace)
    are the fit's. The summary gains ``estimator`` and ``fit``: the
    measurements, the down-weighted ones, the NEES and how often it is
    within the chi-square bound that 95 % of errors fall under.

    Parameters
    ----------
    evaluation : Evaluation
        Plain Swazure's evaluation (:func:`~.evaluate.evaluate`).
    estimator : {'least-squares', 'local-least-squares', 'swarm-fit'}, optional
        The whole swarm's fit, each source's own, or the first as the swarm
        solves it (:mod:`.pair_fits`).
    robust : bool, optional
        Whether to reweight and reject outliers (:func:`~.least_squares.solve`).
    corrupt : callable, optional
        Alters the measurements first (a test's or a benchmark's outliers).

    Returns
    -------
    Evaluation
        The same pairs with the fit's estimates, and their summary.

    Raises
    ------
    ValueError
        ``estimator`` is not a least-squares estimator.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> run = evaluate(swarm, sensor, "shortest-length")
    >>> fitted = refine(run)
    >>> fitted.summary.fit.estimator, fitted.pairs.covariance.shape
    ('least-squares', (2, 3, 3))
    """
    if estimator not in (LEAST_SQUARES, LOCAL_LEAST_SQUARES, SWARM_FIT):
        raise ValueError(f"{estimator!r} is not a least-squares estimator")
    if estimator != LOCAL_LEAST_SQUARES:
        whole = WholeFitEstimates(evaluation.hood, estimator, robust, corrupt)
        updated = whole.block(evaluation.pairs)
        fit = whole.facts()
    else:
        result, windows = _own_fits(evaluation, robust, corrupt)
        updated = _with_fit(evaluation.pairs, result.estimate, result.covariance)
        fit = FitFacts(
            estimator,
            consistency(updated),
            window_flss=windows.flss,
            window_ms=windows.ms,
            path_fallback_pairs=windows.fallback_pairs,
            robust=robust,
            measurements=result.measurements,
            downweighted=result.downweighted,
            seconds=result.seconds,
        )
    took = (evaluation.summary.seconds or 0.0) + (fit.seconds or 0.0)
    summary = summarise(evaluation.hood, evaluation.policy, updated, took, fit=fit)
    return replace(evaluation, pairs=updated, summary=summary)


def _with_fit(pairs: PairResults, estimate: FloatArray, covariance: FloatArray) -> PairResults:
    """``pairs`` with a fit's estimates and covariances (NaN without a path); predicted errors
    the square roots of the covariances' traces."""
    has_path = pairs.status != NO_PATH
    estimate = np.where(has_path[:, None], estimate, np.nan)
    covariance = np.where(has_path[:, None, None], covariance, np.nan)
    predicted = np.sqrt(np.trace(covariance, axis1=1, axis2=2))
    return pairs.with_estimates(estimate, predicted_error=predicted, covariance=covariance)


class WholeFitEstimates:
    """A fit of the whole swarm's measurements given to a run's pairs, one block at a time.

    The fit is solved once (:class:`~.pair_fits.WholeFits`); each pair's
    estimate and covariance are read off it and its NEES tallied, so a run
    made in blocks (:mod:`.blocks`) gets the pairs and the facts that
    :func:`refine` gives all pairs at once (the NEES's quantiles exact while
    they fit ``exact_values``, :class:`~.tally.RealTally`).

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood; with the decaying pairs in sight when a
        decaying pair may join two parts of ``S_vis`` (:func:`needs_decaying`).
    estimator : {'least-squares', 'swarm-fit'}
    robust : bool, optional
    corrupt : callable, optional
        As for :func:`refine`.
    exact_values : int, optional
        NEES values kept for exact quantiles.
    free : int, optional
        Bytes of memory free: a least-squares fit whose dense inverse would
        not fit is solved by conjugate gradients, its covariance sampled
        (:class:`~.pair_fits.WholeFits`); None: dense, as :func:`refine`.
    progress : Progress, optional
        Told of the solves of a swarm fit, which are made at once (a
        least-squares fit's, made for the first block that needs it, are told
        to the progress :meth:`block` is lent).
    """

    def __init__(
        self,
        hood: Neighbourhood,
        estimator: str,
        robust: bool = True,
        corrupt: Corruption | None = None,
        exact_values: int = EXACT_VALUES,
        free: int | None = None,
        progress: Progress = SILENT,
    ) -> None:
        if estimator not in BLOCKED_ESTIMATORS:
            raise ValueError(f"{estimator!r} is not a fit of the whole swarm")
        self.estimator, self.robust = estimator, robust
        swarm = estimator == SWARM_FIT
        self.fits = WholeFits(hood, robust, corrupt, swarm=swarm, free=free, progress=progress)
        self.nees = RealTally(exact_values)
        self.within = 0

    def block(self, pairs: PairResults, progress: Progress = SILENT) -> PairResults:
        """``pairs`` (a block of the run's) with the fit's estimates and covariances; a fit
        that the block is the first to need is solved, shown on ``progress``."""
        estimate, covariance = self.fits.estimates(
            pairs.source, pairs.target, pairs.status == SWEET_PATH, progress
        )
        updated = _with_fit(pairs, estimate, covariance)
        # NaN for a pair without a path: its estimate is NaN.
        nees = normalized_errors(updated.estimate - updated.truth, covariance)
        known = nees[np.isfinite(nees)]
        self.nees.add(known)
        self.within += int((known <= CHI2_95_3DOF).sum())
        return updated

    def facts(self) -> FitFacts:
        """The summary's ``fit``: of every block given so far."""
        result = self.fits.result(np.zeros((0, 3)), np.zeros((0, 3, 3)))
        count = self.nees.count
        return FitFacts(
            self.estimator,
            Consistency(
                nees=self.nees.describe(),
                within_chi2_95_pct=float(100.0 * (self.within / count)) if count else float("nan"),
            ),
            iterations=result.iterations if self.estimator == SWARM_FIT else None,
            robust=self.robust,
            measurements=result.measurements,
            downweighted=result.downweighted,
            seconds=result.seconds,
        )


def needs_decaying(hood: Neighbourhood) -> bool:
    """Whether a fit of ``hood`` may take a decaying pair: ``S_vis`` leaves FLSs apart.

    A fit takes a decaying pair only where it joins two parts of the sweet
    pairs in sight (:func:`~.fit_measurements.joining`): with every FLS in one
    part, the sweet pairs alone give the fit's rows, and a neighbourhood
    without the decaying pairs (``blocks.LeanNeighbourhood.sweet``) serves.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood (its sweet pairs at least).

    Returns
    -------
    bool
        True when ``S_vis`` has more than one part.
    """
    components = hood.sweet_visible_components
    return bool(len(components) and components.max() > 0)


class _Windows(NamedTuple):
    """What the sources' own fits report: their windows' FLSs, their times, ms, and the pairs
    beyond a window that took their path's sum; None for the other estimators."""

    flss: Stats | None = None
    ms: Stats | None = None
    fallback_pairs: int | None = None


def _own_fits(
    evaluation: Evaluation, robust: bool, corrupt: Corruption | None
) -> tuple[PairFit, _Windows]:
    """Each source's own fit of its pairs, a pair beyond its window taking its path's sum."""
    pairs = evaluation.pairs
    has_path = pairs.status != NO_PATH
    arguments = (evaluation.hood, pairs.source, pairs.target, pairs.status == SWEET_PATH)
    result, seconds, sizes = local_estimates(*arguments, robust, corrupt)
    # A target the window does not join to its source gets its path's sum.
    beyond = has_path & np.isnan(result.estimate).any(axis=1)
    if beyond.any():
        fallback, fallback_cov = path_estimates(evaluation.hood, pairs)
        result.estimate[beyond] = fallback[beyond]
        result.covariance[beyond] = fallback_cov[beyond]
    windows = _Windows(
        describe(sizes.astype(np.float64)), describe(1000.0 * seconds), int(beyond.sum())
    )
    return result, windows
