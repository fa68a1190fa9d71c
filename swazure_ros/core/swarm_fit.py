"""The swarm's own least-squares fit: every FLS's position from messages with its neighbours only.

:func:`~.least_squares.solve` finds every position from every measurement at once, in
one place. Here the same weighted normal equations ``H x = b`` are solved
by the swarm: each FLS holds its own three unknowns, the rows of ``H`` and
``b`` its own measured pairs give, and per iteration exchanges one vector
with the FLSs it measures and adds two numbers to a sum over the swarm.
The method is conjugate gradients preconditioned by each FLS's own 3 x 3
block (block Jacobi) in Chronopoulos and Gear's form, which needs one
exchange and one sum per iteration; the robust loss reweights between
solves as :func:`~.least_squares.solve` does, each solve starting where the last
ended. docs/core.md ("The swarm's fit") says why conjugate gradients and
not Gaussian belief propagation, and how it converges.

Every function here works on one FLS's rows as on the whole swarm's, so a
node and the engine run the same arithmetic; the sums over the swarm are
:func:`math.fsum`, exact, so the order in which processes add them changes
nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from .arrays import FloatArray, IntArray
from .draws import standard_normals
from .measurement_graph import (
    CONVERGED_CM,
    ROBUST_ROUNDS,
    Measurements,
    parts_of,
    robust_weights,
)

#: A solve has settled when each column's residual, in the preconditioner's norm, is this
#: small against its right side's: (r, M r) <= SETTLED^2 (b, M b). Both are sums the
#: swarm makes anyway. Not a step's size: on the published sensor's ill-conditioned system
#: (exact directions, weights whose axes differ by 1e6) steps shrink long before the
#: error does, and a solve stopped at steps of 1e-6 cm was 1e-3 cm off.
SETTLED = 1e-10
#: Iterations of one solve, at most (the race car needs a few hundred; docs/core.md).
MAX_ITERATIONS = 5000
#: Iterations without any column's residual halving after which a solve has stalled.
STALL_ITERATIONS = 500
#: Right sides of the covariance's solve: each a draw of every measurement's noise. The
#: sample covariance of K solutions is the fit's covariance to about sqrt(2 / K); a NEES
#: taken with it averages 3 K / (K - 4), the inverse of a sample covariance being biased.
COVARIANCE_SAMPLES = 64
#: The seed of those draws; each measurement's are fixed by it and its two FLS ids.
SAMPLE_SEED = 5


@dataclass(frozen=True)
class Edges:
    """The 2E directed edges of E measured pairs, sorted by (receiver, sender).

    Edge k carries the pair's factor to ``receiver[k]``: its information (the
    sum of both measurements' weights, each scaled by its robust weight) and
    ``flow``, each measurement's information times its vector, oriented
    sender -> receiver and summed.
    """

    sender: IntArray  # (2E,)
    receiver: IntArray  # (2E,)
    starts: IntArray  # (N + 1,), edges into FLS i at starts[i]:starts[i + 1]
    rows: IntArray  # (2E, 2), the pair's measurements: the low end's, then the high end's
    information: FloatArray  # (2E, 3, 3), cm^-2
    flow: FloatArray  # (2E, 3), cm^-1

    @property
    def size(self) -> int:
        return len(self.starts) - 1


def edges_of(size: int, measured: Measurements) -> Edges:
    """The directed edges of ``measured``'s pairs over ``size`` FLSs; each pair measured twice."""
    low = np.minimum(measured.first, measured.second)
    high = np.maximum(measured.first, measured.second)
    order = np.lexsort((measured.second, measured.first, high, low))
    key = low[order] * size + high[order]
    first_of = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else order
    if (np.diff(np.r_[first_of, len(order)]) != 2).any():
        raise ValueError("every measured pair must be measured from both ends")
    pair_rows = order[first_of[:, None] + np.arange(2)]
    pair_low, pair_high = low[pair_rows[:, 0]], high[pair_rows[:, 0]]
    sender = np.concatenate([pair_low, pair_high])
    receiver = np.concatenate([pair_high, pair_low])
    rows = np.concatenate([pair_rows, pair_rows])
    sort = np.lexsort((sender, receiver))
    starts = np.searchsorted(receiver[sort], np.arange(size + 1))
    empty = np.zeros((len(sort), 3, 3)), np.zeros((len(sort), 3))
    edges = Edges(sender[sort], receiver[sort], starts, rows[sort], *empty)
    return weighted(edges, measured, np.ones(len(measured)))


def weighted(edges: Edges, measured: Measurements, weights: FloatArray) -> Edges:
    """``edges`` with factors from ``measured`` (M rows) scaled by robust ``weights`` (M,)."""
    information = measured.information[edges.rows] * weights[edges.rows][:, :, None, None]
    flow = flows(edges, measured, information, measured.vectors[:, :, None])[:, :, 0]
    return replace(edges, information=information[:, 0] + information[:, 1], flow=flow)


def flows(
    edges: Edges, measured: Measurements, information: FloatArray, vectors: FloatArray
) -> FloatArray:
    """Each edge's flow (2E, 3, K), cm^-1, for K columns of measured ``vectors`` (M, 3, K).

    ``information`` (2E, 2, 3, 3) holds each edge's two rows' weights.
    """
    pulled = blocks_times(information, vectors[edges.rows])
    # A row measures first -> second; an edge's flow runs sender -> receiver.
    along = np.where(measured.first[edges.rows] == edges.sender[:, None], 1.0, -1.0)
    return np.asarray(
        along[:, 0, None, None] * pulled[:, 0] + along[:, 1, None, None] * pulled[:, 1],
        dtype=np.float64,
    )


def sums_into(values: FloatArray, starts: IntArray) -> FloatArray:
    """Per FLS, the sum of ``values`` (2E, ...) over the edges into it, in edge order."""
    total = np.zeros((len(starts) - 1, *values.shape[1:]))
    into = np.diff(starts) > 0
    if into.any():
        total[into] = np.add.reduceat(values, starts[:-1][into], axis=0)
    return total


@dataclass(frozen=True)
class System:
    """Each FLS's rows of ``H X = B`` for K right sides: its diagonal block, its B, its edges."""

    edges: Edges
    matrix: Any  # scipy.sparse CSR (3N, 3N), cm^-2: H, each row's columns ascending
    preconditioner: FloatArray  # (N, 3, 3), cm^2: each diagonal block's inverse
    right: FloatArray  # (N, 3, K), cm^-1: B, the flows into the FLS


def system_of(edges: Edges, edge_flows: FloatArray | None = None) -> System:
    """The normal equations' rows held by each FLS of ``edges``; right sides from
    ``edge_flows`` (2E, 3, K), by default the measurements' own (K = 1). An FLS
    in no pair keeps the identity for its block, so that its unknowns stay put."""
    from scipy.sparse import coo_matrix

    diagonal = sums_into(edges.information, edges.starts)
    alone = np.diff(edges.starts) == 0
    diagonal[alone] = np.eye(3)
    size = edges.size
    axes = np.arange(3)
    fls = np.arange(size)
    rows = np.concatenate([3 * fls[:, None, None] + axes[None, :, None],
                           3 * edges.receiver[:, None, None] + axes[None, :, None]])  # fmt: skip
    columns = np.concatenate([3 * fls[:, None, None] + axes[None, None, :],
                              3 * edges.sender[:, None, None] + axes[None, None, :]])  # fmt: skip
    values = np.concatenate([diagonal, -edges.information])
    rows, columns = np.broadcast_arrays(rows, columns)
    matrix = coo_matrix(
        (values.ravel(), (rows.ravel(), columns.ravel())), shape=(3 * size, 3 * size)
    ).tocsr()
    matrix.sort_indices()
    edge_flows = edges.flow[:, :, None] if edge_flows is None else edge_flows
    right = sums_into(edge_flows, edges.starts)
    return System(edges, matrix, np.asarray(np.linalg.inv(diagonal), dtype=np.float64), right)


def product(system: System, vector: FloatArray) -> FloatArray:
    """``H`` times ``vector`` (N, 3, K): each FLS's rows, from its and its neighbours' values."""
    size, _, count = vector.shape
    flat = system.matrix @ vector.reshape(3 * size, count)
    return np.asarray(flat, dtype=np.float64).reshape(size, 3, count)


def preconditioned(system: System, residual: FloatArray) -> FloatArray:
    """Each FLS's residual (N, 3, K), cm^-1, through its own block's inverse: cm."""
    return blocks_times(system.preconditioner, residual)


def blocks_times(blocks: FloatArray, vectors: FloatArray) -> FloatArray:
    """Each 3 x 3 block (..., 3, 3) times its vectors (..., 3, K).

    Written out term by term: numpy's matmul and einsum pick their loops by
    the size of the stack, so an FLS multiplying its one block and the
    engine multiplying every FLS's would differ in the last bit, and an
    ill-conditioned solve would take a different number of iterations.
    """
    return np.asarray(
        blocks[..., :, 0, None] * vectors[..., 0, None, :]
        + blocks[..., :, 1, None] * vectors[..., 1, None, :]
        + blocks[..., :, 2, None] * vectors[..., 2, None, :],
        dtype=np.float64,
    )


def partial_dot(one: FloatArray, other: FloatArray) -> FloatArray:
    """Each FLS's share (N, K) of the K dot products of two (N, 3, K) vectors."""
    return np.asarray((one * other).sum(axis=1), dtype=np.float64)


def swarm_sum(partials: FloatArray) -> FloatArray:
    """The sums (K,) over the swarm of every FLS's shares (N, K): exact, so in any order."""
    return np.array([math.fsum(column) for column in partials.T.tolist()], dtype=np.float64)


@dataclass(frozen=True)
class Iterate:
    """What every FLS holds between iterations of one solve, and the swarm's scalars."""

    position: FloatArray  # (N, 3, K), cm: X
    residual: FloatArray  # (N, 3, K), cm^-1: R = B - H X
    search: FloatArray  # (N, 3, K), cm: P
    image: FloatArray  # (N, 3, K), cm^-1: S = H P
    gamma: FloatArray  # (K,): (r, M r) of the last iteration; zero before the first
    alpha: FloatArray  # (K,): its step length


def shares(system: System, residual: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """U = M R, and W = H U (an exchange of U); every FLS's shares (N, 2, K) of (R, U), (W, U)."""
    scaled = preconditioned(system, residual)
    image = product(system, scaled)
    partial = np.stack([partial_dot(residual, scaled), partial_dot(image, scaled)], axis=1)
    return scaled, image, partial


def scalars(
    iterate: Iterate, gamma: FloatArray, delta: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The steps alpha (K,) and conjugations beta (K,) from the swarm's sums (Chronopoulos and
    Gear's conjugate gradients); a column already exact (gamma zero) stays where it is."""
    first = iterate.gamma == 0.0
    safe_gamma = np.where(first, 1.0, iterate.gamma)
    safe_alpha = np.where(iterate.alpha == 0.0, 1.0, iterate.alpha)
    beta = np.where(first, 0.0, gamma / safe_gamma)
    divisor = delta - beta * gamma / safe_alpha
    alpha = np.divide(gamma, divisor, out=np.zeros_like(gamma), where=divisor != 0.0)
    return alpha, beta


def advance(
    iterate: Iterate,
    scaled: FloatArray,
    image: FloatArray,
    gamma: FloatArray,
    alpha: FloatArray,
    beta: FloatArray,
) -> Iterate:
    """One iteration at every FLS from its U, W and the swarm's scalars."""
    search = scaled + beta * iterate.search
    product_image = image + beta * iterate.image
    return Iterate(
        iterate.position + alpha * search,
        iterate.residual - alpha * product_image,
        search,
        product_image,
        gamma,
        alpha,
    )


def start_iterate(system: System, position: FloatArray) -> Iterate:
    """The iterate at ``position`` (N, 3, K), after an exchange of positions."""
    zeros = np.zeros_like(position)
    columns = np.zeros(position.shape[2])
    return Iterate(position, system.right - product(system, position), zeros, zeros, columns,
                   columns)  # fmt: skip


def solved(
    system: System, position: FloatArray, limit: int = MAX_ITERATIONS
) -> tuple[FloatArray, int]:
    """``H X = B`` by the swarm's iterations from ``position`` (N, 3, K); X and the iterations.

    The first exchange also sums (B, M B), the scale the residuals settle
    against. A solve that stalls (:class:`Floor`) ends at its best iterate.
    """
    iterate = start_iterate(system, position)
    scale = swarm_sum(partial_dot(system.right, preconditioned(system, system.right)))
    floor = Floor.start(position)
    for iteration in range(1, limit + 1):
        scaled, image, partial = shares(system, iterate.residual)
        gamma, delta = swarm_sum(partial[:, 0]), swarm_sum(partial[:, 1])
        if settled(gamma, scale):
            return iterate.position, iteration - 1
        floor = floor.after(gamma, iterate.position)
        if floor.stalled:
            return floor.position, iteration - 1
        alpha, beta = scalars(iterate, gamma, delta)
        iterate = advance(iterate, scaled, image, gamma, alpha, beta)
    return iterate.position, limit


@dataclass(frozen=True)
class Floor:
    """Each column's lowest residual so far, the position that had it, and the iterations since
    any column's last halved: a solve whose residual stops falling has reached the floor
    that rounding puts under an ill-conditioned system (the published sensor's, whose weights'
    axes differ by up to 1e10), where (r, M r) wanders while the positions no longer move."""

    gamma: FloatArray  # (K,), the lowest (r, M r) of each column
    position: FloatArray  # (N, 3, K) or one FLS's (1, 3, K), cm, where each column had it
    since: int = 0

    @classmethod
    def start(cls, position: FloatArray) -> Floor:
        return cls(np.full(position.shape[2], np.inf), position.copy())

    @property
    def stalled(self) -> bool:
        return self.since >= STALL_ITERATIONS

    def after(self, gamma: FloatArray, position: FloatArray) -> Floor:
        """The floor once an iteration at ``position`` has had residuals ``gamma`` (K,)."""
        halved = gamma <= 0.5 * self.gamma
        if not halved.any():
            return replace(self, since=self.since + 1)
        best = self.position.copy()
        best[:, :, halved] = position[:, :, halved]
        return Floor(np.where(halved, gamma, self.gamma), best, 0)


def settled(gamma: FloatArray, scale: FloatArray) -> bool:
    """Whether every column's residual (gamma, K) is small against its right side's (scale)."""
    return bool((gamma <= SETTLED**2 * scale).all())


@dataclass(frozen=True)
class SwarmFit:
    """The swarm's fit: positions, and what the swarm spent on them."""

    positions: FloatArray  # (N, 3), cm, relative to the smallest index of the FLS's part
    part: IntArray  # (N,), connected part of the measurement graph; -1 for an FLS alone
    iterations: list[int]  # per solve: its iterations (one exchange and one sum each)
    downweighted: int  # measurements the robust loss weighed below one in the end
    samples: FloatArray  # (N, 3, K), cm: the covariance's solutions; K = 0 without them

    @property
    def solves(self) -> int:
        return len(self.iterations)

    def relative(self, source: IntArray, target: IntArray) -> tuple[FloatArray, FloatArray]:
        """x_target - x_source (M, 3), cm, and its sample covariance (M, 3, 3), cm^2; nan
        across parts, and the covariance nan without samples."""
        same = (self.part[source] == self.part[target]) & (self.part[source] >= 0)
        estimate = np.full((len(source), 3), np.nan)
        estimate[same] = self.positions[target[same]] - self.positions[source[same]]
        covariance = np.full((len(source), 3, 3), np.nan)
        count = self.samples.shape[2]
        if count:
            spread = self.samples[target[same]] - self.samples[source[same]]
            covariance[same] = np.matmul(spread, np.swapaxes(spread, 1, 2)) / count
        return estimate, covariance


#: How a solve weighs the measurements: all alike, by Huber's loss, or rejecting those far out.
UNIT, HUBER, REJECTING = 0, 1, 2


def weights_for(measured: Measurements, positions: FloatArray, mode: int) -> FloatArray:
    """The weight (M,) of each measurement under ``mode`` at ``positions`` (N, 3), cm."""
    if mode == UNIT:
        return np.ones(len(measured))
    return robust_weights(measured, positions, rejecting=mode == REJECTING)


def robust_decision(
    rejecting: bool, huber_same: bool, rejecting_same: bool, solves: int
) -> int | None:
    """The weights of the next solve (HUBER or REJECTING), or None: the fit is done.

    :func:`~.least_squares.solve`'s schedule: Huber's weights until they repeat, then
    rejection until the rejected set repeats, at most ``ROBUST_ROUNDS``
    reweightings. ``*_same``: whether each mode's weights at the last
    solution equal the weights it was solved with (over the swarm, every FLS's
    say). The engine and the coordinator both decide here.
    """
    if solves > ROBUST_ROUNDS:
        return None
    if not rejecting:
        if not huber_same:
            return HUBER
        rejecting = True
    return None if rejecting_same else REJECTING


def swarm_solve(
    size: int,
    measured: Measurements,
    robust: bool = True,
    start: FloatArray | None = None,
    samples: int = COVARIANCE_SAMPLES,
    ids: IntArray | None = None,
) -> SwarmFit:
    """The fit of ``size`` FLSs from ``measured`` by the swarm's iterations; see the module.

    The robust loss follows :func:`robust_decision`, each solve from the last
    one's positions. ``start`` (N, 3), cm: where the first solve starts (a
    swarm that moved starts from its last fit, a warm start); zero by
    default. Then one more solve with ``samples`` right sides, each a draw of
    every measurement's noise at its final weight, whose solutions' spread is
    the fit's covariance (:func:`noise_flows`; ``ids`` (N,), the FLS ids its
    draws are keyed by, the indices by default).
    """
    ids = np.arange(size, dtype=np.int64) if ids is None else ids
    edges = edges_of(size, measured)
    position = np.zeros((size, 3, 1))
    if start is not None:
        position[:, :, 0] = np.nan_to_num(start)
    position, spent = solved(system_of(edges), position)
    iterations = [spent]
    weights = weights_for(measured, position[:, :, 0], UNIT)
    rejecting = False
    while robust:
        at = position[:, :, 0]
        candidates = {mode: weights_for(measured, at, mode) for mode in (HUBER, REJECTING)}
        mode = robust_decision(
            rejecting,
            np.array_equal(candidates[HUBER], weights),
            np.array_equal(candidates[REJECTING], weights),
            len(iterations),
        )
        if mode is None:
            break
        rejecting = mode == REJECTING
        weights = candidates[mode]
        before = position
        position, spent = solved(system_of(weighted(edges, measured, weights)), position)
        iterations.append(spent)
        if np.abs(position - before).max(initial=0.0) <= CONVERGED_CM:
            # Huber's loss has settled: from here on, measurements far out are rejected.
            rejecting = True
    part = parts_of(size, measured)
    positions = gauged(position[:, :, 0], part)
    drawn = np.zeros((size, 3, 0))
    if samples:
        final = weighted(edges, measured, weights)
        system = system_of(final, noise_flows(final, measured, weights, samples, ids))
        drawn, spent = solved(system, np.zeros((size, 3, samples)))
        iterations.append(spent)
    return SwarmFit(positions, part, iterations, int((weights < 1.0).sum()), drawn)


def noise_flows(
    edges: Edges, measured: Measurements, weights: FloatArray, samples: int, ids: IntArray
) -> FloatArray:
    """Edge flows (2E, 3, K) of K draws of every measurement's noise, N(0, C_m / w_m).

    The fit's solution is linear in the measurements, so the solutions of
    these right sides spread as the fit's errors do: their sample covariance
    estimates H^-1 without forming it. Each measurement's draws are fixed by
    ``SAMPLE_SEED`` and its two FLS ids (``ids`` (N,) of the indices), so an
    FLS draws its neighbour's too.
    """
    values, axes = np.linalg.eigh(measured.covariance)
    root = blocks_times(
        axes * np.sqrt(np.maximum(values, 0.0))[:, None, :], np.swapaxes(axes, 1, 2)
    )
    keys = [ids[measured.first], ids[measured.second]]
    normals = standard_normals(SAMPLE_SEED, keys, 3 * samples)
    noise = blocks_times(root, normals.reshape(-1, 3, samples)) / np.sqrt(weights)[:, None, None]
    information = measured.information[edges.rows] * weights[edges.rows][:, :, None, None]
    return flows(edges, measured, information, noise)


def gauged(position: FloatArray, part: IntArray) -> FloatArray:
    """``position`` (N, 3) with each part's FLS of the smallest index at the origin; nan alone."""
    out = np.full_like(position, np.nan)
    for one in np.unique(part[part >= 0]):
        members = np.flatnonzero(part == one)
        out[members] = position[members] - position[members[0]]
    return out
