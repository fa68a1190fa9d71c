"""The swarm's conjugate gradients: ``H X = B`` solved by neighbour exchanges and sums.

Each FLS holds its own rows of the weighted normal equations (:class:`System`,
from the edges of :mod:`.swarm_edges`); an iteration in Chronopoulos and Gear's
form takes one exchange with the FLSs it measures and two sums over the swarm
(:func:`shares`, :func:`swarm_sum`, :func:`scalars`, :func:`advance`),
preconditioned by each FLS's own 3 x 3 block (block Jacobi). The sums are
:func:`math.fsum`, exact, so the order in which processes add them changes
nothing. docs/core.md ("The swarm's fit") says how a solve converges.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from . import jit
from .arrays import FloatArray
from .conjugate_steps import (
    advance_in_place,
    dots_into,
    image_with_shares,
    product_into,
    scaled_with_shares,
)
from .exact_sums import swarm_sum
from .progress import SILENT, Progress, Share
from .swarm_edges import Edges, blocks_times, sums_into

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


@dataclass(frozen=True)
class System:
    """Each FLS's rows of ``H X = B`` for K right sides: its diagonal block, its B, its edges."""

    edges: Edges
    matrix: Any  # scipy.sparse CSR (3N, 3N), cm^-2: H, each row's columns ascending
    preconditioner: FloatArray  # (N, 3, 3), cm^2: each diagonal block's inverse
    right: FloatArray  # (N, 3, K), cm^-1: B, the flows into the FLS


def system_of(
    edges: Edges, edge_flows: FloatArray | None = None, right: FloatArray | None = None
) -> System:
    """The normal equations' rows held by each FLS of ``edges``.

    An FLS in no pair keeps the identity for its block, so that its unknowns
    stay put.

    Parameters
    ----------
    edges : Edges
        Weighted edges of N FLSs.
    edge_flows : (2E, 3, K) array of float, optional, cm^-1
        The right sides' flows; by default the measurements' own (K = 1).
    right : (N, 3, K) array of float, optional, cm^-1
        The right sides themselves, each FLS's flows summed
        (:func:`~.swarm_edges.summed_flows`), instead of ``edge_flows``.

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
    if right is None:
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
    return sparse_times(system.matrix, vector.reshape(3 * size, count)).reshape(size, 3, count)


def sparse_times(matrix: Any, vector: FloatArray) -> FloatArray:
    """A sparse matrix times a block of column vectors, as scipy's product gives it.

    Where this process compiles its kernels, every row on every thread
    (:func:`.conjugate_steps.product_into`): each row is added up in the order
    scipy adds it, so the same bits, without scipy's single thread and its
    checks each call.

    Parameters
    ----------
    matrix : scipy.sparse CSR (R, C)
    vector : (C, K) array of float

    Returns
    -------
    (R, K) array of float
    """
    if jit.INTERPRET:
        return np.asarray(matrix @ vector, dtype=np.float64)
    image = np.empty((matrix.shape[0], vector.shape[1]))
    values = np.ascontiguousarray(matrix.data, dtype=np.float64)
    dense = np.ascontiguousarray(vector, dtype=np.float64)
    product_into(matrix.indptr, matrix.indices, values, dense, image)
    return image


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
    if not jit.INTERPRET and one.shape == other.shape and one.ndim == 3:
        out = np.empty((one.shape[0], one.shape[2]))
        flat = functools.partial(np.ascontiguousarray, dtype=np.float64)
        dots_into(flat(one), flat(other), out)
        return out
    return np.asarray((one * other).sum(axis=1), dtype=np.float64)


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
    if not jit.INTERPRET and scaled.ndim == 3:
        # The next vectors overwrite copies: the iterate given stays as it was.
        flat = functools.partial(np.ascontiguousarray, dtype=np.float64)
        moved = replace(_copied(iterate), gamma=gamma, alpha=alpha)
        advance_in_place(moved.position, moved.residual, moved.search, moved.image,
                         flat(scaled), flat(image), flat(alpha), flat(beta))  # fmt: skip
        return moved
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
    system: System,
    position: FloatArray,
    limit: int = MAX_ITERATIONS,
    progress: Progress = SILENT,
    stage: str = "conjugate gradients",
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
    progress : Progress, optional
        Told of ``stage``, in hundredths of the way from the first residual to
        the settled one (:func:`settled_share`).
    stage : str, optional
        The stage's name.

    Returns
    -------
    position : (N, 3, K) array of float, cm
        X; not yet gauged (:func:`~.swarm_fit.gauged`).
    iterations : int
        Each one exchange and one sum over the swarm.
    """
    iterate = start_iterate(system, position)
    scale = swarm_sum(partial_dot(system.right, preconditioned(system, system.right)))
    floor = Floor.start(position)
    shown = Share(progress, stage)
    steps = _Fresh(system) if jit.INTERPRET else _InPlace(system, position.shape)
    iterate = steps.own(iterate)
    for iteration in range(1, limit + 1):
        scaled, image, gamma_shares, delta_shares = steps.shares(iterate.residual)
        gamma, delta = swarm_sum(gamma_shares), swarm_sum(delta_shares)
        if settled(gamma, scale):
            shown.reach(1.0)
            return iterate.position, iteration - 1
        shown.reach(settled_share(gamma, scale))
        floor = floor.after(gamma, iterate.position)
        if floor.stalled:
            return floor.position, iteration - 1
        alpha, beta = scalars(iterate, gamma, delta)
        iterate = steps.advance(iterate, scaled, image, gamma, alpha, beta)
    return iterate.position, limit


def _copied(iterate: Iterate) -> Iterate:
    """``iterate`` with its four vectors copied, each C-contiguous: arrays to overwrite."""
    owned = functools.partial(np.array, dtype=np.float64, order="C")
    return Iterate(owned(iterate.position), owned(iterate.residual), owned(iterate.search),
                   owned(iterate.image), iterate.gamma, iterate.alpha)  # fmt: skip


class _Fresh:
    """An iteration's vectors by :func:`shares` and :func:`advance`, each a new array."""

    def __init__(self, system: System) -> None:
        self.system = system

    def own(self, iterate: Iterate) -> Iterate:
        return iterate

    def shares(
        self, residual: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """U, W, and each FLS's shares of (R, U) and (W, U)."""
        scaled, image, partial = shares(self.system, residual)
        return scaled, image, partial[:, 0], partial[:, 1]

    def advance(
        self,
        iterate: Iterate,
        scaled: FloatArray,
        image: FloatArray,
        gamma: FloatArray,
        alpha: FloatArray,
        beta: FloatArray,
    ) -> Iterate:
        """The next iterate (:func:`advance`)."""
        return advance(iterate, scaled, image, gamma, alpha, beta)


class _InPlace(_Fresh):
    """The same iteration compiled into arrays held for the whole solve
    (:mod:`.conjugate_steps`): the same bits, without a new 100 MB array per vector and
    step at a display's size."""

    def __init__(self, system: System, shape: tuple[int, ...]) -> None:
        super().__init__(system)
        matrix = system.matrix
        self.matrix = (matrix.indptr, matrix.indices, np.ascontiguousarray(matrix.data))
        self.blocks = np.ascontiguousarray(system.preconditioner, dtype=np.float64)
        self.scaled, self.image = np.empty(shape), np.empty(shape)
        self.gamma_shares, self.delta_shares = np.empty((2, shape[0], shape[2]))

    def own(self, iterate: Iterate) -> Iterate:
        """The iterate in arrays of the solve's own, which its steps overwrite."""
        return _copied(iterate)

    def shares(
        self, residual: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        scaled_with_shares(self.blocks, residual, self.scaled, self.gamma_shares)
        flat = self.scaled.reshape(-1, self.scaled.shape[2])
        image = self.image.reshape(flat.shape)
        image_with_shares(*self.matrix, flat, image, self.delta_shares)
        return self.scaled, self.image, self.gamma_shares, self.delta_shares

    def advance(
        self,
        iterate: Iterate,
        scaled: FloatArray,
        image: FloatArray,
        gamma: FloatArray,
        alpha: FloatArray,
        beta: FloatArray,
    ) -> Iterate:
        """The next iterate, its vectors overwriting this one's."""
        advance_in_place(iterate.position, iterate.residual, iterate.search, iterate.image,
                         scaled, image, alpha, beta)  # fmt: skip
        return replace(iterate, gamma=gamma, alpha=alpha)


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
        best = np.where(halved, position, self.position)
        return Floor(np.where(halved, gamma, self.gamma), best, 0)


def settled_share(gamma: FloatArray, scale: FloatArray) -> float:
    """How far a solve has come to :func:`settled`, 0 to 1: of the digits its residual must
    lose, the share lost by its worst column so far.

    Parameters
    ----------
    gamma, scale : (K,) array of float
        As for :func:`settled`.

    Returns
    -------
    float
        ``log(max gamma / scale) / log(SETTLED**2)``, within [0, 1]; 1 when
        every column with a right side has a zero residual.

    Examples
    --------
    >>> import numpy as np
    >>> settled_share(np.array([1e-5, 1e-10]), np.array([1.0, 1.0]))
    0.25
    """
    ratio = np.divide(gamma, scale, out=np.zeros_like(gamma), where=scale > 0).max(initial=0.0)
    if ratio <= 0.0:
        return 1.0
    return float(min(1.0, max(0.0, math.log(ratio) / math.log(SETTLED**2))))


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
