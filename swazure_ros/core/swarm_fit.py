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
    """The directed edges of ``measured``'s pairs over ``size`` FLSs; each pair measured twice.

    Each measured pair gives two edges, one into each of its FLSs, carrying
    both of its measurements at unit robust weight (:func:`weighted`).

    Parameters
    ----------
    size : int
        FLSs, N; more than every index of ``measured``.
    measured : Measurements
        M rows; every pair measured exactly twice, once from each end.

    Returns
    -------
    Edges
        2E = M edges, sorted by (receiver, sender).

    Raises
    ------
    ValueError
        A pair measured from one end only, or more than once from an end.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])  # cm
    >>> first, second = np.array([0, 1, 2, 1, 0, 2]), np.array([1, 2, 0, 0, 2, 1])
    >>> eye = np.broadcast_to(np.eye(3), (6, 3, 3))  # each measurement's variance: 1 cm^2
    >>> measured = Measurements(first, second, points[second] - points[first], eye, eye)
    >>> from swazure_ros.core.swarm_fit import edges_of
    >>> edges = edges_of(3, measured)
    >>> edges.receiver.tolist(), edges.sender.tolist()
    ([0, 0, 1, 1, 2, 2], [1, 2, 0, 2, 0, 1])
    """
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
    """``edges`` with their factors from ``measured``, each row scaled by its robust weight.

    Parameters
    ----------
    edges : Edges
        :func:`edges_of` ``measured``.
    measured : Measurements
        M rows.
    weights : (M,) array of float
        Each row's robust weight, in (0, 1].

    Returns
    -------
    Edges
        The same edges; ``information`` (2E, 3, 3), cm^-2, the sum of the
        pair's two weighted rows, and ``flow`` (2E, 3), cm^-1.
    """
    information = measured.information[edges.rows] * weights[edges.rows][:, :, None, None]
    flow = flows(edges, measured, information, measured.vectors[:, :, None])[:, :, 0]
    return replace(edges, information=information[:, 0] + information[:, 1], flow=flow)


def flows(
    edges: Edges, measured: Measurements, information: FloatArray, vectors: FloatArray
) -> FloatArray:
    """Each edge's flow, cm^-1: its two rows' information times their vectors, summed.

    A row measures first -> second; an edge's flow runs sender -> receiver,
    so a row measured the other way counts negatively.

    Parameters
    ----------
    edges : Edges
    measured : Measurements
        M rows.
    information : (2E, 2, 3, 3) array of float, cm^-2
        Each edge's two rows' information, as weighted.
    vectors : (M, 3, K) array of float, cm
        K columns of measured vectors (or of noise draws).

    Returns
    -------
    (2E, 3, K) array of float, cm^-1
    """
    pulled = blocks_times(information, vectors[edges.rows])
    # A row measures first -> second; an edge's flow runs sender -> receiver.
    along = np.where(measured.first[edges.rows] == edges.sender[:, None], 1.0, -1.0)
    return np.asarray(
        along[:, 0, None, None] * pulled[:, 0] + along[:, 1, None, None] * pulled[:, 1],
        dtype=np.float64,
    )


def sums_into(values: FloatArray, starts: IntArray) -> FloatArray:
    """Per FLS, the sum of ``values`` over the edges into it, in edge order.

    Parameters
    ----------
    values : (2E, ...) array of float
        One value per edge, edges sorted by receiver.
    starts : (N + 1,) array of int
        ``Edges.starts``: FLS i's edges at ``starts[i]:starts[i + 1]``.

    Returns
    -------
    (N, ...) array of float
        Zero for an FLS with no edge.
    """
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
    """The normal equations' rows held by each FLS of ``edges``.

    An FLS in no pair keeps the identity for its block, so that its unknowns
    stay put.

    Parameters
    ----------
    edges : Edges
        Weighted edges of N FLSs.
    edge_flows : (2E, 3, K) array of float, optional, cm^-1
        The right sides' flows; by default the measurements' own (K = 1).

    Returns
    -------
    System
        ``H`` (3N, 3N) sparse, cm^-2; each diagonal block's inverse, cm^2;
        the right sides ``B`` (N, 3, K), cm^-1.
    """
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
    """``H`` times ``vector``: each FLS's rows, from its and its neighbours' values.

    Parameters
    ----------
    system : System
    vector : (N, 3, K) array of float, cm

    Returns
    -------
    (N, 3, K) array of float, cm^-1
    """
    size, _, count = vector.shape
    flat = system.matrix @ vector.reshape(3 * size, count)
    return np.asarray(flat, dtype=np.float64).reshape(size, 3, count)


def preconditioned(system: System, residual: FloatArray) -> FloatArray:
    """Each FLS's residual through its own block's inverse (block Jacobi).

    Parameters
    ----------
    system : System
    residual : (N, 3, K) array of float, cm^-1

    Returns
    -------
    (N, 3, K) array of float, cm
    """
    return blocks_times(system.preconditioner, residual)


def blocks_times(blocks: FloatArray, vectors: FloatArray) -> FloatArray:
    """Each 3 x 3 block times its vectors, the same bits for one block as for a stack.

    Written out term by term: numpy's matmul and einsum pick their loops by
    the size of the stack, so an FLS multiplying its one block and the
    engine multiplying every FLS's would differ in the last bit, and an
    ill-conditioned solve would take a different number of iterations.

    Parameters
    ----------
    blocks : (..., 3, 3) array of float
    vectors : (..., 3, K) array of float

    Returns
    -------
    (..., 3, K) array of float

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.swarm_fit import blocks_times
    >>> blocks_times(2.0 * np.eye(3)[None], np.ones((1, 3, 1)))[..., 0]
    array([[2., 2., 2.]])
    """
    return np.asarray(
        blocks[..., :, 0, None] * vectors[..., 0, None, :]
        + blocks[..., :, 1, None] * vectors[..., 1, None, :]
        + blocks[..., :, 2, None] * vectors[..., 2, None, :],
        dtype=np.float64,
    )


def partial_dot(one: FloatArray, other: FloatArray) -> FloatArray:
    """Each FLS's share of the K dot products of two vectors of the swarm.

    Parameters
    ----------
    one, other : (N, 3, K) array of float

    Returns
    -------
    (N, K) array of float
        :func:`swarm_sum` adds them up.
    """
    return np.asarray((one * other).sum(axis=1), dtype=np.float64)


def swarm_sum(partials: FloatArray) -> FloatArray:
    """The sums over the swarm of every FLS's shares: exact, so in any order.

    ``math.fsum``, correctly rounded: a process's exact sum, rounded once,
    is what the engine gets over every FLS at once.

    Parameters
    ----------
    partials : (N, K) array of float

    Returns
    -------
    (K,) array of float

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.swarm_fit import swarm_sum
    >>> swarm_sum(np.array([[1e16, 1.0], [1.0, 2.0], [-1e16, 3.0]]))  # no 1.0 lost
    array([1., 6.])
    """
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
    """U = M R and W = H U (an exchange of U), and every FLS's shares of (R, U) and (W, U).

    The one exchange and the two sums of an iteration in Chronopoulos and
    Gear's form.

    Parameters
    ----------
    system : System
    residual : (N, 3, K) array of float, cm^-1
        R.

    Returns
    -------
    scaled : (N, 3, K) array of float, cm
        U.
    image : (N, 3, K) array of float, cm^-1
        W.
    partial : (N, 2, K) array of float
        Each FLS's shares of (R, U) and (W, U).
    """
    scaled = preconditioned(system, residual)
    image = product(system, scaled)
    partial = np.stack([partial_dot(residual, scaled), partial_dot(image, scaled)], axis=1)
    return scaled, image, partial


def scalars(
    iterate: Iterate, gamma: FloatArray, delta: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The steps alpha and conjugations beta from the swarm's sums (Chronopoulos and Gear).

    A column already exact (gamma zero) stays where it is.

    Parameters
    ----------
    iterate : Iterate
        The last iteration's gamma and alpha.
    gamma, delta : (K,) array of float
        This iteration's sums (R, U) and (W, U).

    Returns
    -------
    alpha, beta : (K,) array of float
    """
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
    """One iteration at every FLS from its U, W and the swarm's scalars.

    Parameters
    ----------
    iterate : Iterate
    scaled : (N, 3, K) array of float, cm
        U (:func:`shares`).
    image : (N, 3, K) array of float, cm^-1
        W.
    gamma, alpha, beta : (K,) array of float
        The swarm's sum (R, U) and :func:`scalars`.

    Returns
    -------
    Iterate
    """
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
    """The iterate at ``position``, after an exchange of positions.

    Parameters
    ----------
    system : System
    position : (N, 3, K) array of float, cm

    Returns
    -------
    Iterate
        Residual ``B - H X``; no search direction yet.
    """
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

    Parameters
    ----------
    system : System
    position : (N, 3, K) array of float, cm
        Where the solve starts.
    limit : int, default MAX_ITERATIONS
        Iterations, at most.

    Returns
    -------
    position : (N, 3, K) array of float, cm
        X; not yet gauged (:func:`gauged`).
    iterations : int
        Each one exchange and one sum over the swarm.
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
    """Whether every column's residual is small against its right side's.

    Parameters
    ----------
    gamma : (K,) array of float
        Each column's (r, M r).
    scale : (K,) array of float
        Each column's (b, M b).

    Returns
    -------
    bool
        ``gamma <= SETTLED**2 * scale`` for every column.
    """
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
        """Each target's position relative to its source, and its sample covariance.

        Parameters
        ----------
        source, target : (M,) array of int
            Swarm indices.

        Returns
        -------
        estimate : (M, 3) array of float, cm
            x_target - x_source; NaN across parts or for an FLS in none.
        covariance : (M, 3, 3) array of float, cm^2
            The sample covariance over the fit's samples; NaN without samples.
        """
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
    """The weight of each measurement under ``mode`` at ``positions``.

    Parameters
    ----------
    measured : Measurements
        M rows.
    positions : (N, 3) array of float, cm
    mode : {UNIT, HUBER, REJECTING}

    Returns
    -------
    (M,) array of float
        Ones for UNIT; :func:`~.measurement_graph.robust_weights` otherwise.
    """
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

    Parameters
    ----------
    rejecting : bool
        Whether the last solve rejected (past Huber's loss).
    huber_same, rejecting_same : bool
        Whether each mode's weights repeat.
    solves : int
        Solves so far.

    Returns
    -------
    int or None
        HUBER or REJECTING, or None.

    Examples
    --------
    >>> from swazure_ros.core.swarm_fit import HUBER, REJECTING, robust_decision
    >>> robust_decision(False, False, False, 1) == HUBER  # Huber's weights changed
    True
    >>> robust_decision(False, True, False, 2) == REJECTING  # they repeat: now reject
    True
    >>> robust_decision(True, True, True, 3) is None  # the rejected set repeats: done
    True
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
    the fit's covariance (:func:`noise_flows`).

    Parameters
    ----------
    size : int
        FLSs, N.
    measured : Measurements
        M rows, each pair measured from both ends.
    robust : bool, default True
        Reweight by the robust loss; False: one solve at unit weights.
    start : (N, 3) array of float, optional, cm
        Where the first solve starts (NaN rows: 0).
    samples : int, default COVARIANCE_SAMPLES (64)
        Right sides of the covariance's solve; 0 for none.
    ids : (N,) array of int, optional
        The FLS ids the draws are keyed by; the indices by default.

    Returns
    -------
    SwarmFit
        Positions (N, 3), cm, each part's FLS of the smallest index at the
        origin; the iterations of every solve; the samples.

    Raises
    ------
    ValueError
        A pair measured from one end only (:func:`edges_of`).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])  # cm
    >>> first, second = np.array([0, 1, 2, 1, 0, 2]), np.array([1, 2, 0, 0, 2, 1])
    >>> eye = np.broadcast_to(np.eye(3), (6, 3, 3))  # each measurement's variance: 1 cm^2
    >>> measured = Measurements(first, second, points[second] - points[first], eye, eye)
    >>> from swazure_ros.core.swarm_fit import swarm_solve
    >>> fit = swarm_solve(3, measured, samples=0)
    >>> fit.positions.round(9)
    array([[0., 0., 0.],
           [7., 0., 0.],
           [0., 7., 0.]])
    >>> estimate, _ = fit.relative(np.array([1]), np.array([2]))
    >>> estimate.round(9)
    array([[-7.,  7.,  0.]])
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
    ``SAMPLE_SEED`` and its two FLS ids, so an FLS draws its neighbour's too.

    Parameters
    ----------
    edges : Edges
    measured : Measurements
        M rows.
    weights : (M,) array of float
        The final robust weights.
    samples : int
        Draws, K.
    ids : (N,) array of int
        The FLS id of each index.

    Returns
    -------
    (2E, 3, K) array of float, cm^-1
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
    """``position`` with each part's FLS of the smallest index at the origin.

    Relative measurements fix positions only up to a translation per part.

    Parameters
    ----------
    position : (N, 3) array of float, cm
    part : (N,) array of int
        Each FLS's connected part; -1 for an FLS in no measurement.

    Returns
    -------
    (N, 3) array of float, cm
        NaN for an FLS in no part.
    """
    out = np.full_like(position, np.nan)
    for one in np.unique(part[part >= 0]):
        members = np.flatnonzero(part == one)
        out[members] = position[members] - position[members[0]]
    return out
