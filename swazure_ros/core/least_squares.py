"""The weighted least-squares solve: N FLSs' positions from measured vectors between them.

A weighted least-squares fit over the measurement graph (Barooah and
Hespanha, "Estimation on graphs from relative measurements", 2007) finds
the positions x that best explain every measured vector v_ij ~ x_j - x_i,
each weighted by the inverse of its covariance
(:func:`~.hop_errors.hop_covariance`); :func:`solve` returns them as a
:class:`Fit`, one gauge per connected part, with their covariance, and a
pair's relative position x_target - x_source with its own. docs/core.md
("The least-squares fit") derives the weights, the gauge and the robust loss.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np

from .arrays import BoolArray, FloatArray, IntArray
from .measurement_graph import (
    CONVERGED_CM,
    ROBUST_ROUNDS,
    Measurements,
    parts_of,
    robust_weights,
)
from .progress import SILENT, Progress

#: A round factors its normal matrix anew when more than this share of the weights
#: differ from those of the last factors; otherwise conjugate gradients, preconditioned
#: by those factors, solve it in a few steps (a clean run changes a few weights only).
REFACTOR_SHARE = 0.01


@dataclass(frozen=True)
class Fit:
    """Positions of N FLSs from a least-squares fit, one gauge per connected part."""

    positions: FloatArray  # (N, 3), cm, relative to the anchor of the FLS's part; nan if alone
    part: IntArray  # (N,), connected part of the measurement graph; -1 for an FLS alone
    # Per part of K FLSs, the covariance (3K - 3, 3K - 3), cm^2, of all but its anchor
    # (whose position is the origin, exactly); only the lower triangle is filled.
    covariance: list[FloatArray]
    slot: IntArray  # (N,), the FLS's place among its part's FLSs
    downweighted: int  # measurements the robust loss weighed below one in the end
    rounds: int  # reweighting rounds run

    def relative(self, source: IntArray, target: IntArray) -> tuple[FloatArray, FloatArray]:
        """x_target - x_source (M, 3), cm, and its covariance (M, 3, 3), cm^2; nan across parts."""
        same = (self.part[source] == self.part[target]) & (self.part[source] >= 0)
        estimate = np.full((len(source), 3), np.nan)
        estimate[same] = self.positions[target[same]] - self.positions[source[same]]
        covariance = np.full((len(source), 3, 3), np.nan)
        for part in np.unique(self.part[source[same]]):
            rows = np.flatnonzero(same & (self.part[source] == part))
            lower = self.covariance[part]
            a, c = self.slot[source[rows]], self.slot[target[rows]]

            def block(first: IntArray, second: IntArray, lower: FloatArray = lower) -> FloatArray:
                """Covariance blocks (R, 3, 3) at slots ``first``, ``second``; 0 at the anchor."""
                row = 3 * (first[:, None, None] - 1) + np.arange(3)[None, :, None]
                column = 3 * (second[:, None, None] - 1) + np.arange(3)[None, None, :]
                anchor = (first == 0) | (second == 0)
                row, column = np.broadcast_arrays(row, column)
                values = lower[np.maximum(row, column), np.minimum(row, column)]
                values[anchor] = 0.0
                return np.asarray(values, dtype=np.float64)

            covariance[rows] = block(c, c) + block(a, a) - block(a, c) - block(c, a)
        return estimate, covariance


def _information(
    size: int, measured: Measurements, information: FloatArray
) -> tuple[Any, FloatArray]:
    """Normal equations H x = b: H sparse (3N, 3N), cm^-2, and b (3N,), cm^-1.

    ``information`` (M, 3, 3) is each measurement's weight matrix, the
    inverse of its covariance scaled by the robust loss's weight.
    """
    from scipy.sparse import coo_matrix

    axes = np.arange(3)
    i = 3 * measured.first[:, None] + axes
    j = 3 * measured.second[:, None] + axes
    rows, cols, values = [], [], []
    for left, right, sign in ((i, i, 1.0), (j, j, 1.0), (i, j, -1.0), (j, i, -1.0)):
        rows.append(np.broadcast_to(left[:, :, None], information.shape).ravel())
        cols.append(np.broadcast_to(right[:, None, :], information.shape).ravel())
        values.append(sign * information.ravel())
    matrix = coo_matrix(
        (np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
        shape=(3 * size, 3 * size),
    ).tocsc()
    return matrix, _scatter(size, measured, np.einsum("mab,mb->ma", information, measured.vectors))


def _scatter(size: int, measured: Measurements, flow: FloatArray) -> FloatArray:
    """A^T of per-measurement vectors (M, 3): +flow at the measured FLS, -flow at the measuring."""
    total = np.zeros((size, 3))
    np.add.at(total, measured.second, flow)
    np.add.at(total, measured.first, -flow)
    return total.ravel()


def solve(
    size: int, measured: Measurements, robust: bool = True, progress: Progress = SILENT
) -> Fit:
    """The weighted least-squares positions of N FLSs from measured vectors between them.

    The gauge: in each connected part, the FLS of the smallest index is the
    origin. With ``robust``, iteratively reweighted least squares with
    Huber's loss on each measurement's Mahalanobis residual
    (``HUBER_THRESHOLD``): a gross error's pull stops growing with its size;
    once that has settled, the measurements beyond ``OUTLIER_THRESHOLD`` are
    rejected (a convex start, then a redescending step), until the rejected
    set repeats. A reweighted system is factored anew when many weights
    changed (:data:`REFACTOR_SHARE`), else solved by conjugate gradients
    preconditioned with the last factors; the final one exactly, by its own.
    The covariance is the inverse of the final normal matrix, per part.

    Parameters
    ----------
    size : int
        N, the FLSs (indices 0 to N - 1).
    measured : Measurements
        M measured vectors, cm, from ``first`` to ``second``, with their
        covariances, cm^2, and information matrices, cm^-2.
    robust : bool, optional
        Whether to reweight and reject outliers; else one weighted solve.
    progress : Progress, optional
        Told of each factoring as a stage.

    Returns
    -------
    Fit
        Each FLS's position, cm, from its part's anchor (NaN for an FLS in
        no measurement), its part, and the covariance of each part.

    Raises
    ------
    numpy.linalg.LinAlgError
        A part's normal matrix is singular (a covariance without inverse).

    Examples
    --------
    A triangle measured around once, and one side back:

    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> eye = np.broadcast_to(np.eye(3), (4, 3, 3))
    >>> vectors = np.array([[7.0, 0, 0], [-7, 7, 0], [0, -7, 0], [-7, 0, 0]])
    >>> first, second = np.array([0, 1, 2, 1]), np.array([1, 2, 0, 0])
    >>> fit = solve(3, Measurements(first, second, vectors, eye, eye))
    >>> fit.positions.round(9).tolist()
    [[0.0, 0.0, 0.0], [7.0, 0.0, 0.0], [0.0, 7.0, 0.0]]
    >>> estimate, covariance = fit.relative(np.array([1]), np.array([2]))
    >>> estimate.round(9).tolist(), covariance.shape
    ([[-7.0, 7.0, 0.0]], (1, 3, 3))
    """
    part = parts_of(size, measured)
    members, free, blocks = _gauge(size, part)

    def factorise(normal: Any) -> _DenseFactors:
        return _DenseFactors(_factors(normal, blocks), blocks)

    solution, dense, weights, rounds = _reweighted(
        size, measured, free, factorise, robust, progress
    )
    positions = np.zeros(3 * size)
    positions[free] = solution
    slot = np.zeros(size, dtype=np.int64)
    covariance = []
    for group, factor in zip(members, dense.factors, strict=True):
        slot[group] = np.arange(len(group))
        covariance.append(_part_covariance(factor))
    points = positions.reshape(size, 3)
    points[part < 0] = np.nan
    return Fit(points, part, covariance, slot, int((weights < 1.0).sum()), rounds)


def _gauge(size: int, part: IntArray) -> tuple[list[IntArray], BoolArray, list[IntArray]]:
    """Each part's FLSs, the free unknowns (3N,), and each part's unknowns among those.

    Each part's FLSs in index order; the first is its anchor, the origin of
    the gauge, and has no unknowns.
    """
    parts = int(part.max()) + 1 if len(part) else 0
    order = np.lexsort((np.arange(size), part))
    order = order[part[order] >= 0]
    members = np.split(order, np.searchsorted(part[order], np.arange(1, parts))) if parts else []
    unknown = part >= 0
    unknown[[group[0] for group in members]] = False
    free = np.repeat(unknown, 3)
    # The unknowns of each part, as positions among the free unknowns.
    slot_of = np.cumsum(free) - 1
    return members, free, [slot_of[_axes(group[1:])] for group in members]


class _Factor(Protocol):
    """A factored normal matrix: the solution of its system for a right side (or several)."""

    def __call__(self, rhs: FloatArray) -> FloatArray: ...


_F = TypeVar("_F", bound=_Factor)


@dataclass(frozen=True)
class _DenseFactors:
    """The lower Cholesky factors of each part's dense block (:func:`_factors`)."""

    factors: list[FloatArray]
    blocks: list[IntArray]

    def __call__(self, rhs: FloatArray) -> FloatArray:
        return _solve(self.factors, self.blocks, rhs)


def _shown(factorise: Callable[[Any], _F], progress: Progress) -> Callable[[Any], _F]:
    """``factorise``, each call shown as a stage of one unit: a factor is one call into
    LAPACK, which says nothing until it returns."""

    def shown(normal: Any) -> _F:
        progress.start(f"fit: factoring {normal.shape[0]:,} unknowns", 1)
        factors = factorise(normal)
        progress.advance(1)
        return factors

    return shown


def _reweighted(
    size: int,
    measured: Measurements,
    free: BoolArray,
    factorise: Callable[[Any], _F],
    robust: bool,
    progress: Progress = SILENT,
) -> tuple[FloatArray, _F, FloatArray, int]:
    """The free unknowns' solution, the final factors, the final weights and the rounds.

    One weighted solve, then (``robust``) the rounds of :func:`solve`'s
    reweighting; the final system factored by its own weights. Each factoring
    is a stage of ``progress``.
    """
    factorise = _shown(factorise, progress)
    information = measured.information
    matrix, rhs = _information(size, measured, information)
    normal = matrix[free][:, free].tocsr()
    factors = factorise(normal)
    solution = factors(rhs[free])
    weights = factored = np.ones(len(measured))
    rounds = 0
    rejecting = False
    while robust and rounds < ROBUST_ROUNDS:
        positions = np.zeros(3 * size)
        positions[free] = solution
        points = positions.reshape(size, 3)
        updated = robust_weights(measured, points, rejecting)
        if np.array_equal(updated, weights):
            if rejecting:
                break
            rejecting = True
            continue
        weights = updated
        rounds += 1
        previous = solution
        matrix, rhs = _information(size, measured, information * weights[:, None, None])
        normal = matrix[free][:, free].tocsr()
        if np.mean(weights != factored) > REFACTOR_SHARE:
            factors, factored = factorise(normal), weights
            solution = factors(rhs[free])
        else:
            solution = _preconditioned(normal, rhs[free], factors, previous)
        settled = np.abs(solution - previous).max(initial=0.0) <= CONVERGED_CM
        if settled:
            # Huber's loss has settled: from here on, measurements far out are rejected.
            rejecting = True
    if not np.array_equal(weights, factored):
        factors = factorise(normal)
        solution = factors(rhs[free])
    return solution, factors, weights, rounds


def _axes(flss: IntArray) -> IntArray:
    """The 3 unknowns of each FLS, in order: (3K,)."""
    return np.asarray((3 * flss[:, None] + np.arange(3)).ravel(), dtype=np.int64)


def _factors(normal: Any, blocks: list[IntArray]) -> list[FloatArray]:
    """The lower Cholesky factor of each part's dense block of ``normal``.

    Dense: a connected part's normal matrix fills in almost completely when
    factored (SuperLU took 10-17 s on the race car's 11,154 unknowns, LAPACK
    5 s), and its dense inverse is wanted anyway.
    """
    from scipy.linalg import cho_factor

    factors = []
    for block in blocks:
        dense = normal[block][:, block].toarray(order="F")
        factor, _ = cho_factor(dense, lower=True, overwrite_a=True, check_finite=False)
        factors.append(factor)
    return factors


def _solve(factors: list[FloatArray], blocks: list[IntArray], rhs: FloatArray) -> FloatArray:
    """The solution of the block-diagonal system whose parts' factors are ``factors``."""
    from scipy.linalg import cho_solve

    out = np.zeros_like(rhs)
    for factor, block in zip(factors, blocks, strict=True):
        out[block] = cho_solve((factor, True), rhs[block], check_finite=False)
    return out


def _preconditioned(
    normal: Any, rhs: FloatArray, factors: _Factor, start: FloatArray
) -> FloatArray:
    """``normal`` x = ``rhs`` by conjugate gradients from ``start``; ``factors`` precondition."""
    from scipy.sparse.linalg import LinearOperator, cg

    count = normal.shape[0]
    preconditioner = LinearOperator((count, count), matvec=factors, dtype=np.float64)
    solution, _ = cg(normal, rhs, x0=start, rtol=1e-12, atol=0.0, M=preconditioner)
    return np.asarray(solution, dtype=np.float64)


def _part_covariance(factor: FloatArray) -> FloatArray:
    """The covariance of a part's unknowns, cm^2, from its normal matrix's Cholesky factor.

    LAPACK's inverse, in place of the factor; only its lower triangle is
    filled (:meth:`Fit.relative` reads that one), which saves a copy of a
    matrix of a gigabyte on the race car.
    """
    from scipy.linalg.lapack import dpotri

    if factor.size == 0:
        return factor
    inverse, info = dpotri(factor, lower=1, overwrite_c=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"the fit's normal matrix is singular ({info})")
    return np.asarray(inverse, dtype=np.float64)


def dense_bytes(size: int, measured: Measurements) -> int:
    """Bytes :func:`solve` holds for its parts' dense factors and covariances, at the least.

    Parameters
    ----------
    size : int
        N, the FLSs.
    measured : Measurements

    Returns
    -------
    int, bytes
        8 bytes per entry of each part's (3K - 3) x (3K - 3) normal matrix.
    """
    part = parts_of(size, measured)
    members = np.bincount(part[part >= 0])
    return int((8 * (3 * members - 3) ** 2).sum())
