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

import numpy as np

from .arrays import FloatArray
from .errors import SwazureError
from .evaluation import NO_PATH, SWEET_PATH, Evaluation, PairResults
from .fit_measurements import Corruption
from .geometry import tracking_distance
from .heuristics.result import PLAIN
from .metrics import describe
from .neighbourhood import Neighbourhood
from .pair_fits import fit_pairs_estimates, local_estimates
from .pair_statistics import summarise
from .path_arrays import Paths, path_hops
from .sensor import (
    hop_covariance,
    measured_vectors,
    unbiased_vectors,
)
from .summary import Consistency, FitFacts

#: The estimators of a pair's pose: the paper's sum along the policy's path; the fit over
#: the whole swarm's measurements; each source's own fit over what it hears by radio; the
#: same fit as the first, solved by the swarm's messages with measured neighbours only.
PATH, LEAST_SQUARES, LOCAL_LEAST_SQUARES = "path", "least-squares", "local-least-squares"
SWARM_FIT = "swarm-fit"
ESTIMATORS = (PATH, LEAST_SQUARES, LOCAL_LEAST_SQUARES, SWARM_FIT)


def check_plain_estimator(estimator: str, technique: str = PLAIN, fuse: int = 1) -> None:
    """A fit estimates plain Swazure's pairs alone: SwazureError naming the options
    (``--fuse``, ``--technique``) that ask for fused paths or a heuristic's moves too."""
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
    """Each pair's path sum with the bias removed (M, 3), cm, and its covariance (M, 3, 3), cm^2.

    What a source whose window does not reach its target falls back on: the
    measured hops of the policy's path, each without the sensor's known bias
    (:func:`~.sensor.unbiased_vectors`), and the sum of their covariances
    (independent hops). Nan without a path.
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
    """Normalized estimation error squared e^T C^-1 e: errors (M, 3), cm; covariances (M, 3, 3)."""
    known = np.isfinite(error).all(axis=1) & np.isfinite(covariance).all(axis=(1, 2))
    out = np.full(len(error), np.nan)
    if known.any():
        solved = np.linalg.solve(covariance[known], error[known][:, :, None])[:, :, 0]
        out[known] = np.einsum("ma,ma->m", error[known], solved)
    return out


def consistency(pairs: PairResults) -> Consistency:
    """How honest ``pairs``' covariances are: their NEES, and how often it is within chi2 95 %."""
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
    """``evaluation`` with every estimate from a least-squares ``estimator``, and its covariance.

    Statuses, reasons and the reported paths stay the policy's (which pairs
    a sweet or a decaying hop joins); estimates, errors and predicted errors
    (the square root of the covariance's trace) are the fit's. The summary
    gains ``estimator`` and ``fit``: the measurements, the down-weighted ones,
    the normalized estimation error squared (NEES) and how often it is
    within the chi-square bound that 95 % of errors fall under; the swarm's
    fit its iterations too.
    """
    if estimator not in (LEAST_SQUARES, LOCAL_LEAST_SQUARES, SWARM_FIT):
        raise ValueError(f"{estimator!r} is not a least-squares estimator")
    local = estimator == LOCAL_LEAST_SQUARES
    pairs = evaluation.pairs
    has_path = pairs.status != NO_PATH
    arguments = (evaluation.hood, pairs.source, pairs.target, pairs.status == SWEET_PATH)
    window_flss = window_ms = None
    fallback_pairs = None
    if local:
        result, seconds, sizes = local_estimates(*arguments, robust, corrupt)
        # A target the window does not join to its source gets its path's sum.
        beyond = has_path & np.isnan(result.estimate).any(axis=1)
        if beyond.any():
            fallback, fallback_cov = path_estimates(evaluation.hood, pairs)
            result.estimate[beyond] = fallback[beyond]
            result.covariance[beyond] = fallback_cov[beyond]
        window_flss, window_ms = describe(sizes.astype(np.float64)), describe(1000.0 * seconds)
        fallback_pairs = int(beyond.sum())
    else:
        result = fit_pairs_estimates(*arguments, robust, corrupt, swarm=estimator == SWARM_FIT)
    estimate = np.where(has_path[:, None], result.estimate, np.nan)
    covariance = np.where(has_path[:, None, None], result.covariance, np.nan)
    predicted = np.sqrt(np.trace(covariance, axis1=1, axis2=2))
    updated = pairs.with_estimates(estimate, predicted_error=predicted, covariance=covariance)
    fit = FitFacts(
        estimator,
        consistency(updated),
        window_flss=window_flss,
        window_ms=window_ms,
        path_fallback_pairs=fallback_pairs,
        iterations=tuple(result.iterations) if estimator == SWARM_FIT else None,
        robust=robust,
        measurements=result.measurements,
        downweighted=result.downweighted,
        seconds=result.seconds,
    )
    took = (evaluation.summary.seconds or 0.0) + result.seconds
    summary = summarise(evaluation.hood, evaluation.policy, updated, took, fit=fit)
    return replace(evaluation, pairs=updated, summary=summary)
