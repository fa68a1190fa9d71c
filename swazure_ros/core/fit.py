"""Least-squares localization: every FLS's position from all the swarm's measurements at once.

A path's estimate sums the measured vectors of one chain of hops and
carries every error of that chain. The swarm measures far more: every
visible sweet pair, from both ends. A weighted least-squares fit over that
measurement graph (Barooah and Hespanha, "Estimation on graphs from
relative measurements", 2007) finds the positions x that best explain
every measured vector v_ij ~ x_j - x_i, each weighted by the inverse of its
covariance (:func:`~.sensor.hop_covariance`); a source's estimate of a blind
neighbour is then x_target - x_source, with a covariance from the fit.
docs/core.md ("The least-squares fit") derives the weights, the gauge, how
decaying hops join the sweet parts and the robust loss.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import csr
from .arrays import FloatArray, IntArray
from .draws import standard_normals, uniforms
from .errors import SwazureError
from .evaluation import NO_PATH, SWEET_PATH, Evaluation, PairResults
from .frames import through_metres
from .geometry import tracking_distance
from .heuristics.result import PLAIN
from .measurement_graph import (
    CONVERGED_CM,
    ROBUST_ROUNDS,
    Measurements,
    measured_rows,
    parts_of,
    robust_weights,
)
from .metrics import describe
from .neighbourhood import Neighbourhood
from .observe import Observations
from .pair_statistics import summarise
from .path_arrays import Paths, path_hops
from .sensor import (
    BLIND,
    DECAYING,
    SWEET,
    Sensor,
    hop_covariance,
    measured_vectors,
    unbiased_vectors,
)
from .summary import Consistency, FitFacts
from .swarm_fit import swarm_solve

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
#: A round factors its normal matrix anew when more than this share of the weights
#: differ from those of the last factors; otherwise conjugate gradients, preconditioned
#: by those factors, solve it in a few steps (a clean run changes a few weights only).
REFACTOR_SHARE = 0.01
#: The chi-square bound that 95 % of 3-D errors fall under, when the covariance is right.
CHI2_95_3DOF = 7.8147


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


def joining(
    first: IntArray, second: IntArray, sweet: NDArray[np.bool_], size: int
) -> NDArray[np.bool_]:
    """Which of the hops first[m] - second[m] (M,) are decaying and join two sweet parts.

    ``sweet`` (M,) marks the sweet hops; the parts are the connected
    components of those over ``size`` FLSs. The one rule of which decaying
    hops a fit takes (docs/core.md, "The least-squares fit").
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix(
        (np.ones(int(sweet.sum())), (first[sweet], second[sweet])), shape=(size, size)
    )
    _, part = connected_components(graph, directed=False)
    return np.asarray(~sweet & (part[first] != part[second]), dtype=np.bool_)


def fit_layers(sensor: Sensor) -> tuple[bool, ...]:
    """The fits a sensor's pairs take, each with or without the joining decaying hops.

    A stochastic sensor: one fit with them, for every pair. A deterministic
    one (its bias unknown and alike on every hop): the sweet hops alone for
    the pairs with a sweet path, then a fit with the joining hops for the rest.
    """
    return (True,) if sensor.noise is not None else (False, True)


def fit_pairs(hood: Neighbourhood, links: bool = True) -> IntArray:
    """Indices into ``hood.pairs`` of the measured pairs a fit uses, ascending.

    Every visible sweet pair; with ``links``, also every visible decaying
    pair that joins two parts of S_vis (:func:`joining`).
    """
    pairs = hood.pairs
    measured = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    index = np.flatnonzero(measured & hood.visible & hood.usable)
    sweet = pairs.range_class[index] == SWEET
    if links:
        first, second = pairs.first[index], pairs.second[index]
        sweet = sweet | joining(first, second, sweet, hood.swarm.size)
    return np.asarray(index[sweet], dtype=np.int64)


def measurements(hood: Neighbourhood, index: IntArray) -> Measurements:
    """Both measurements of each pair of ``hood.pairs`` at ``index`` (P,): (2P,), bias removed."""
    swarm, sensor = hood.swarm, hood.sensor
    low, high = hood.pairs.first[index], hood.pairs.second[index]
    first = np.concatenate([low, high])
    second = np.concatenate([high, low])
    raw = measured_vectors(sensor, swarm.points, swarm.radius, first, second)
    tracking = np.tile(hood.pairs.tracking[index], 2)
    return measured_rows(sensor, swarm.radius, first, second, raw, tracking)


def with_outliers(
    measured: Measurements, fraction: float, angle_deg: float, seed: int = 0
) -> Measurements:
    """``measured`` with a ``fraction`` of its vectors turned by ``angle_deg`` about a random axis.

    A stand-in for a camera's gross errors, such as IPPE's mirrored pose: a
    wrong pose puts the FLS's centre, which lies behind the marker, off to
    one side. Which vectors turn and about which axis (normal to the vector)
    is drawn from ``seed`` and the pair, so a run repeats.
    """
    pick = uniforms(seed, [measured.first, measured.second], 1)[:, 0] < fraction
    vectors = measured.vectors.copy()
    chosen = vectors[pick]
    length = np.linalg.norm(chosen, axis=1, keepdims=True)
    unit = chosen / length
    z = standard_normals(seed + 1, [measured.first[pick], measured.second[pick]], 3)
    axis = np.cross(unit, z)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    turn = np.radians(angle_deg)
    # Rodrigues' rotation of a vector about an axis normal to it.
    vectors[pick] = chosen * np.cos(turn) + np.cross(axis, chosen) * np.sin(turn)
    return replace(measured, vectors=vectors)


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


def solve(size: int, measured: Measurements, robust: bool = True) -> Fit:
    """The weighted least-squares positions of ``size`` FLSs from ``measured``; see the module.

    The gauge: in each connected part, the FLS of the smallest index is the
    origin. With ``robust``, iteratively reweighted least squares with
    Huber's loss on each measurement's Mahalanobis residual
    (``HUBER_THRESHOLD``): a gross error's pull stops growing with its size;
    once that has settled, the measurements beyond ``OUTLIER_THRESHOLD`` are
    rejected (a convex start, then a redescending step), until the rejected
    set repeats. A reweighted system is factored anew when many weights
    changed (``REFACTOR_SHARE``), else solved by conjugate gradients
    preconditioned with the last factors; the final one exactly, by its own.
    The covariance is the inverse of the final normal matrix, per part.
    """
    part = parts_of(size, measured)
    parts = int(part.max()) + 1 if len(part) else 0
    # Each part's FLSs in index order; the first is its anchor, the origin of the gauge.
    order = np.lexsort((np.arange(size), part))
    order = order[part[order] >= 0]
    members = np.split(order, np.searchsorted(part[order], np.arange(1, parts))) if parts else []
    unknown = part >= 0
    unknown[[group[0] for group in members]] = False
    free = np.repeat(unknown, 3)
    # The unknowns of each part, as positions among the free unknowns.
    slot_of = np.cumsum(free) - 1
    blocks = [slot_of[_axes(group[1:])] for group in members]
    information = measured.information
    matrix, rhs = _information(size, measured, information)
    normal = matrix[free][:, free].tocsr()
    factors = _factors(normal, blocks)
    solution = _solve(factors, blocks, rhs[free])
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
            factors, factored = _factors(normal, blocks), weights
            solution = _solve(factors, blocks, rhs[free])
        else:
            solution = _preconditioned(normal, rhs[free], factors, blocks, previous)
        settled = np.abs(solution - previous).max(initial=0.0) <= CONVERGED_CM
        if settled:
            # Huber's loss has settled: from here on, measurements far out are rejected.
            rejecting = True
    if not np.array_equal(weights, factored):
        factors = _factors(normal, blocks)
        solution = _solve(factors, blocks, rhs[free])
    positions = np.zeros(3 * size)
    positions[free] = solution
    slot = np.zeros(size, dtype=np.int64)
    covariance = []
    for group, factor in zip(members, factors, strict=True):
        slot[group] = np.arange(len(group))
        covariance.append(_part_covariance(factor))
    points = positions.reshape(size, 3)
    points[part < 0] = np.nan
    return Fit(points, part, covariance, slot, int((weights < 1.0).sum()), rounds)


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
    normal: Any,
    rhs: FloatArray,
    factors: list[FloatArray],
    blocks: list[IntArray],
    start: FloatArray,
) -> FloatArray:
    """``normal`` x = ``rhs`` by conjugate gradients from ``start``; ``factors`` precondition."""
    from scipy.sparse.linalg import LinearOperator, cg

    count = normal.shape[0]
    preconditioner = LinearOperator(
        (count, count), matvec=lambda r: _solve(factors, blocks, r), dtype=np.float64
    )
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


Corruption = Callable[[Measurements], Measurements]


@dataclass(frozen=True)
class PairFit:
    """The fit's estimates of M ordered pairs and what it took."""

    estimate: FloatArray  # (M, 3), cm, target - source; nan where no fit joins the two
    covariance: FloatArray  # (M, 3, 3), cm^2
    measurements: int  # measurements in the fits
    downweighted: int  # of them, those the robust loss weighed below one
    seconds: float
    # The swarm's fit: per fit (two under a deterministic sensor), the iterations of each
    # solve, the covariance's last.
    iterations: tuple[tuple[int, ...], ...] = ()


def fit_pairs_estimates(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
    corrupt: Corruption | None = None,
    swarm: bool = False,
) -> PairFit:
    """Least-squares estimates of the pairs (source[m], target[m]); ``sweet`` marks sweet pairs.

    Under a stochastic sensor one fit serves every pair: its bias is removed
    and its scatter known, so every joining decaying hop only adds what it
    knows. Under a deterministic one (the published quadratic, its bias
    unknown and alike on every hop) a pair with a sweet path is estimated
    from the sweet hops alone, and only the pairs that need a decaying hop
    from a fit with the joining decaying hops. ``corrupt`` alters the
    measurements before the fit (a test's or a benchmark's outliers). With
    ``swarm``, each fit is solved as the swarm solves it (:mod:`.swarm_fit`):
    the same estimates, and a covariance sampled by the swarm.
    """
    began = time.perf_counter()
    size = hood.swarm.size
    estimate = np.full((len(source), 3), np.nan)
    covariance = np.full((len(source), 3, 3), np.nan)
    index = fit_pairs(hood)
    # Measured once: the sweet-only fit takes its rows from the same table.
    every = measurements(hood, index)
    if corrupt is not None:
        every = corrupt(every)
    sweet_rows = np.tile(hood.pairs.range_class[index] == SWEET, 2)
    rows_of = {False: sweet_rows, True: np.ones(len(every), dtype=bool)}
    pairs_of = {(True,): [np.ones(len(source), dtype=bool)], (False, True): [sweet, ~sweet]}
    links = fit_layers(hood.sensor)
    groups = [(rows, rows_of[layer]) for rows, layer in zip(pairs_of[links], links, strict=True)]
    used = downweighted = 0
    iterations: list[tuple[int, ...]] = []
    for rows, chosen in groups:
        # The swarm solves every fit: no FLS knows that no pair of the swarm needs one.
        if not rows.any() and not swarm:
            continue
        measured = _select(every, chosen)
        if swarm:
            solved = swarm_solve(size, measured, robust, ids=hood.swarm.cloud_index)
            estimate[rows], covariance[rows] = solved.relative(source[rows], target[rows])
            iterations.append(tuple(solved.iterations))
        else:
            fit = solve(size, measured, robust)
            estimate[rows], covariance[rows] = fit.relative(source[rows], target[rows])
        used += len(measured)
        downweighted += solved.downweighted if swarm else fit.downweighted
    seconds = time.perf_counter() - began
    return PairFit(estimate, covariance, used, downweighted, seconds, tuple(iterations))


@dataclass(frozen=True)
class Heard:
    """What one source hears: the readings its window's FLSs publish, one row per reading.

    The rows an FLS gets from its radio neighbours' measurements (and its
    own): who measured whom, the range class and tracking distance of the
    pair (ranging by radio, cm) and the measured vector (cm). FLS ids, not
    swarm indices: the same table whether the engine lays it out or a node
    gathers it from messages.
    """

    owner: IntArray  # (R,), the measuring FLS
    other: IntArray  # (R,), the measured FLS
    range_class: NDArray[np.int8]  # (R,), SWEET or DECAYING
    tracking: FloatArray  # (R,), the pair's tracking distance, cm
    vector: FloatArray  # (R, 3), measured vector owner -> other, cm


def heard_in_window(seen: Observations, ids: IntArray, source: int) -> tuple[IntArray, Heard]:
    """The window of the FLS at swarm index ``source`` and the readings it hears there.

    The window is the source and the FLSs within its radio range (its blind
    and sweet neighbours; spec, section 4), as FLS ids, the source first;
    the readings are those of window FLSs of other window FLSs.
    """
    mine = seen.rows(source)
    radio = np.isin(seen.range_class[mine], (BLIND, SWEET))
    members = np.concatenate([[source], seen.other[mine][radio]]).astype(np.int64)
    starts, ends = seen.indptr[members], seen.indptr[members + 1]
    rows = csr.ragged_indices(starts, ends - starts)  # each member's rows, one after another
    owner = np.repeat(members, ends - starts)
    inside = np.zeros(len(ids), dtype=bool)
    inside[members] = True
    keep = seen.measured[rows] & inside[seen.other[rows]]
    rows, owner = rows[keep], owner[keep]
    heard = Heard(
        ids[owner],
        ids[seen.other[rows]],
        seen.range_class[rows],
        seen.distance[rows],
        seen.vector[rows],
    )
    return ids[members], heard


def window_fit(
    sensor: Sensor,
    radius: float,
    window: IntArray,
    heard: Heard,
    targets: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
) -> tuple[FloatArray, FloatArray, int]:
    """A source's own fit of ``targets`` (K,) from what it hears (docs/core.md, "Own fit").

    ``window`` (W,) are FLS ids, the source first; ``heard`` the readings
    between them. The rows are chosen as :func:`fit_pairs` chooses them,
    over the window's own sweet graph, and a deterministic sensor gets the
    same two fits as :func:`fit_pairs_estimates`; ``sweet`` (K,) marks the
    targets with a sweet path. The source is the origin. Rows are taken in
    (owner, other) order, so that a node and the engine sum in one order.
    Returns the estimates (K, 3), cm, their covariances (K, 3, 3), cm^2,
    nan where the window does not join a target to the source, and the rows used.
    """
    order = np.lexsort((heard.other, heard.owner))
    lookup = {int(fls): slot for slot, fls in enumerate(window.tolist())}
    first = np.array([lookup[int(f)] for f in heard.owner[order]], dtype=np.int64)
    second = np.array([lookup[int(f)] for f in heard.other[order]], dtype=np.int64)
    measured = measured_rows(
        sensor, radius, first, second, heard.vector[order], heard.tracking[order]
    )
    is_sweet = heard.range_class[order] == SWEET
    size = len(window)
    links = joining(first, second, is_sweet, size)
    estimate = np.full((len(targets), 3), np.nan)
    covariance = np.full((len(targets), 3, 3), np.nan)
    rows_of = {False: is_sweet, True: is_sweet | links}
    pairs_of = {(True,): [np.ones(len(targets), dtype=bool)], (False, True): [sweet, ~sweet]}
    layers = fit_layers(sensor)
    groups = [(rows, rows_of[layer]) for rows, layer in zip(pairs_of[layers], layers, strict=True)]
    used = 0
    slots = np.array([lookup.get(int(t), -1) for t in targets], dtype=np.int64)
    for rows, chosen in groups:
        wanted = rows & (slots >= 0)
        if not wanted.any() or not chosen.any():
            continue
        fit = solve(size, _select(measured, chosen), robust)
        origin = np.zeros(int(wanted.sum()), dtype=np.int64)
        estimate[wanted], covariance[wanted] = fit.relative(origin, slots[wanted])
        used = max(used, int(chosen.sum()))
    return estimate, covariance, used


def _select(measured: Measurements, rows: NDArray[np.bool_]) -> Measurements:
    """The measurements at ``rows``."""
    return Measurements(
        measured.first[rows],
        measured.second[rows],
        measured.vectors[rows],
        measured.covariance[rows],
        measured.information[rows],
    )


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


def local_estimates(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
    corrupt: Corruption | None = None,
) -> tuple[PairFit, FloatArray, IntArray]:
    """Every pair's estimate from its source's :func:`window_fit`; and per source (in the
    order of ``np.unique(source)``) the seconds of its fit and the FLSs of its window.

    The windows are laid out from :func:`~.observe.observations`, what every
    FLS's senses give its node, as the ``measurements`` messages carry them
    to a source (in metres: :func:`~.frames.through_metres`); swarm indices
    serve as FLS ids. ``corrupt`` alters every reading first (outliers).
    """
    from .observe import observations

    began = time.perf_counter()
    seen = observations(hood)
    # A fit weighs readings whose axes differ by 1e10: the last bit of a reading
    # moves an estimate by up to 1e-9 cm, so the engine reads what the wire carries.
    seen = replace(
        seen, vector=through_metres(seen.vector), distance=through_metres(seen.distance)
    )
    if corrupt is not None:
        rows = np.flatnonzero(seen.measured)
        owner = csr.run_of(seen.indptr)[rows]
        unused = np.zeros((len(rows), 3, 3))
        readings = Measurements(owner, seen.other[rows], seen.vector[rows], unused, unused)
        vector = seen.vector.copy()
        vector[rows] = corrupt(readings).vectors
        seen = replace(seen, vector=vector)
    ids = np.arange(hood.swarm.size, dtype=np.int64)
    estimate = np.full((len(source), 3), np.nan)
    covariance = np.full((len(source), 3, 3), np.nan)
    sources, counts = np.unique(source, return_counts=True)
    order = np.argsort(source, kind="stable")
    ends = np.cumsum(counts)
    seconds = np.zeros(len(sources))
    sizes = np.zeros(len(sources), dtype=np.int64)
    used = 0
    for slot, one in enumerate(sources):
        rows = order[ends[slot] - counts[slot] : ends[slot]]
        tick = time.perf_counter()
        members, heard = heard_in_window(seen, ids, int(one))
        estimate[rows], covariance[rows], measured = window_fit(
            hood.sensor, hood.swarm.radius, members, heard, target[rows], sweet[rows], robust
        )
        seconds[slot] = time.perf_counter() - tick
        sizes[slot] = len(members)
        used = max(used, measured)
    fit = PairFit(estimate, covariance, used, 0, time.perf_counter() - began)
    return fit, seconds, sizes


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
