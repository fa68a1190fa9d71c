"""The measured pairs of the swarm's fit as directed edges, each FLS's share of the factors.

Each pair measured from both ends gives two edges, one into each of its FLSs,
carrying the pair's information and flow (:class:`Edges`); :func:`sums_into`
adds an FLS's edges up, and :func:`blocks_times` multiplies 3 x 3 blocks with
the same bits for one FLS as for the swarm. The swarm's fit
(:mod:`.swarm_fit`) solves over these edges by :mod:`.conjugate_gradients`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import jit
from .arrays import FloatArray, IntArray
from .measurement_graph import Measurements

#: Edges whose flows :func:`flows` forms at once (64 draws: about 50 MB of rows).
FLOW_CHUNK = 16384


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
    >>> from swazure_ros.core.swarm_edges import edges_of
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
    out = np.empty((len(edges.rows), 3, vectors.shape[2]), dtype=np.float64)
    # Edge by edge, so a chunk at a time gives the same bits and holds each edge's two
    # rows of K columns for one chunk only (torus:10000's 64 draws: 12 GB at once).
    for start in range(0, len(out), FLOW_CHUNK):
        part = slice(start, start + FLOW_CHUNK)
        out[part] = _flows_of(edges, measured, information, vectors, part)
    return out


def summed_flows(
    edges: Edges, measured: Measurements, information: FloatArray, vectors: FloatArray
) -> FloatArray:
    """Per FLS, the sum of the flows of the edges into it: ``sums_into(flows(...))``.

    The same bits, formed a few FLSs' edges at a time, so that every edge's K
    columns are never held at once (the race car resampled to 30,000 FLSs, 64
    draws: 5.5 GB).

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
    (N, 3, K) array of float, cm^-1
    """
    starts = edges.starts
    total = np.zeros((len(starts) - 1, 3, vectors.shape[2]))
    begin = 0
    while begin < len(starts) - 1:
        # Whole FLSs a chunk: each FLS's sum runs over its own edges in order, as whole.
        end = max(int(np.searchsorted(starts, starts[begin] + FLOW_CHUNK, "right")) - 1, begin + 1)
        part = slice(int(starts[begin]), int(starts[end]))
        chunk = _flows_of(edges, measured, information, vectors, part)
        total[begin:end] = sums_into(chunk, starts[begin : end + 1] - starts[begin])
        begin = end
    return total


def _flows_of(
    edges: Edges, measured: Measurements, information: FloatArray, vectors: FloatArray, part: slice
) -> FloatArray:
    """:func:`flows` of the edges ``part``."""
    rows = edges.rows[part]
    pulled = blocks_times(information[part], vectors[rows])
    # A row measures first -> second; an edge's flow runs sender -> receiver.
    along = np.where(measured.first[rows] == edges.sender[part, None], 1.0, -1.0)
    return along[:, 0, None, None] * pulled[:, 0] + along[:, 1, None, None] * pulled[:, 1]


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
    >>> from swazure_ros.core.swarm_edges import blocks_times
    >>> blocks_times(2.0 * np.eye(3)[None], np.ones((1, 3, 1)))[..., 0]
    array([[2., 2., 2.]])
    """
    if not jit.INTERPRET and blocks.ndim == vectors.ndim == 3 and len(blocks) == len(vectors):
        out = np.empty(vectors.shape)
        blocks_into(
            np.ascontiguousarray(blocks, dtype=np.float64),
            np.ascontiguousarray(vectors, dtype=np.float64),
            out,
        )
        return out
    # Summed in place, in the order (b0 v0 + b1 v1) + b2 v2: the same bits as one
    # expression, with two (..., 3, K) arrays held rather than five.
    out = np.multiply(blocks[..., :, 0, None], vectors[..., 0, None, :], dtype=np.float64)
    term = np.multiply(blocks[..., :, 1, None], vectors[..., 1, None, :], dtype=np.float64)
    out += term
    np.multiply(blocks[..., :, 2, None], vectors[..., 2, None, :], out=term)
    out += term
    return out


@jit.kernel(cache=True)
def blocks_into(
    blocks: FloatArray, vectors: FloatArray, out: FloatArray
) -> None:  # pragma: no cover - compiled
    """:func:`blocks_times` of a stack into ``out``, in one pass: the same bits.

    Term by term in its order, (b0 v0 + b1 v1) + b2 v2.

    Parameters
    ----------
    blocks : (N, 3, 3) array of float
    vectors : (N, 3, K) array of float
    out : (N, 3, K) array of float
        Filled with each block times its vectors.
    """
    count, _, columns = vectors.shape
    for one in range(count):
        for row in range(3):
            first, second, third = blocks[one, row, 0], blocks[one, row, 1], blocks[one, row, 2]
            for column in range(columns):
                out[one, row, column] = (
                    first * vectors[one, 0, column] + second * vectors[one, 1, column]
                ) + third * vectors[one, 2, column]
