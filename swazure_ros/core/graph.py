"""Neighbour graphs: undirected graphs over FLS indices in CSR form (spec, section 4).

A :class:`Graph`'s edge length is the tracking distance of its pair, cm, and
each edge may carry a cost (its expected error, for the least-error policy)
and a label (the caller's index of its pair). :func:`make_graph` builds one
from edge lists; :mod:`.paths` searches it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import jit
from .arrays import FloatArray, IntArray


@dataclass(frozen=True)
class Graph:
    """An undirected graph in CSR form: neighbours of node v are indices[indptr[v]:indptr[v+1]].

    An edge's cost (its expected error, which the least-error policy sums) is
    given, or computed from its weight by ``cost_of`` when first asked for
    (:meth:`edge_costs`): a display's graphs hold tens of millions of entries,
    and only that policy reads them.
    """

    indptr: IntArray  # (N + 1,)
    indices: IntArray  # (2E,), sorted within each row
    weights: FloatArray  # (2E,), tracking distance of each edge, cm
    labels: IntArray  # (2E,), caller's label of each edge (e.g. its pair index)
    costs: FloatArray | None = None  # (2E,), expected error of each edge (least-error)
    # Elementwise from weights to costs (2E,) -> (2E,), for costs not given.
    cost_of: Callable[[FloatArray], FloatArray] | None = field(default=None, compare=False)
    _computed: dict[str, FloatArray] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def edge_costs(self) -> FloatArray | None:
        """Each entry's cost (2E,), cm or cm^2: given, or ``cost_of(weights)`` computed once.

        Returns
        -------
        (2E,) ndarray of float, or None
            None when the graph was made without costs.
        """
        if self.costs is not None or self.cost_of is None:
            return self.costs
        if "costs" not in self._computed:
            self._computed["costs"] = np.asarray(self.cost_of(self.weights), dtype=np.float64)
        return self._computed["costs"]

    @property
    def size(self) -> int:
        """Number of nodes."""
        return len(self.indptr) - 1

    @property
    def edges(self) -> int:
        """Number of undirected edges."""
        return len(self.indices) // 2

    def edge_positions(self, first: ArrayLike, second: ArrayLike) -> IntArray:
        """Position in ``indices`` of the edge first[m]-second[m] for each m: (M,); -1 if none."""
        return np.asarray(
            _edge_positions(
                self.indptr,
                self.indices,
                np.asarray(first, dtype=np.int64),
                np.asarray(second, dtype=np.int64),
            )
        )

    def edge_labels(self, first: ArrayLike, second: ArrayLike) -> IntArray:
        """Label of the edge first[m]-second[m] for each m: (M,); -1 where there is none."""
        position = self.edge_positions(first, second)
        return np.where(position >= 0, self.labels[position], -1)

    def components(self) -> IntArray:
        """Connected-component label of every node: (N,).

        Numbered in the order of each component's lowest node, as scipy's
        ``connected_components`` numbers them, without importing scipy.sparse
        (0.1 s of a run's start, BENCHMARKS.md "Speed targets").
        """
        return np.asarray(_component_labels(self.indptr, self.indices))


def make_graph(
    size: int,
    first: ArrayLike,
    second: ArrayLike,
    weights: ArrayLike,
    labels: ArrayLike | None = None,
    costs: ArrayLike | None = None,
    cost_of: Callable[[FloatArray], FloatArray] | None = None,
    keep: NDArray[np.bool_] | None = None,
) -> Graph:
    """Undirected graph on ``size`` nodes from edge lists, each edge entered once.

    Parameters
    ----------
    size : int
        N, the number of nodes (FLS indices 0 to N - 1).
    first, second : (E,) array_like of int
        The two ends of each edge, in any order; no edge joins a node to itself.
    weights : (E,) array_like of float, cm
        Each edge's length: its pair's tracking distance.
    labels : (E,) array_like of int, optional
        The caller's tag of each edge (its pair's index); default, its position
        in the lists.
    costs : (E,) array_like of float, cm, optional
        Each edge's expected error (:func:`~.hop_errors.hop_error`), which the
        least-error policy sums.
    cost_of : callable, optional
        Instead of ``costs``: each entry's cost from its weight, elementwise,
        computed when the policy first asks (:meth:`Graph.edge_costs`).
    keep : (E,) array of bool, optional
        Only these edges (labelled by their position in the full lists by
        default), with no copy of the lists (:func:`symmetric_rows`).

    Returns
    -------
    Graph
        Both directions of every edge, each row sorted by neighbour; the
        ``weights``, ``labels`` and ``costs`` (2E,) follow the entries.

    Raises
    ------
    ValueError
        The lists differ in length, an end is not a node, or an edge joins a
        node to itself.

    Examples
    --------
    >>> from swazure_ros.core.graph import make_graph
    >>> graph = make_graph(3, [0, 1], [1, 2], [1.5, 2.0])
    >>> graph.indptr.tolist(), graph.indices.tolist(), graph.weights.tolist()
    ([0, 1, 3, 4], [1, 0, 2, 1], [1.5, 1.5, 2.0, 2.0])
    >>> graph.edge_labels([2], [1]).tolist()
    [1]
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    weights = np.asarray(weights, dtype=np.float64)
    labels = None if labels is None else np.asarray(labels, dtype=np.int64)
    _check_edges(size, first, second, weights, labels, keep)
    if costs is not None and cost_of is not None:
        raise ValueError("give `costs` or `cost_of`, not both")
    indptr, indices, edge = symmetric_rows(size, first, second, keep=keep)
    edge_costs = None
    if costs is not None:
        costs = np.asarray(costs, dtype=np.float64)
        if costs.shape != weights.shape:
            raise ValueError("`costs` must have one value per edge")
        edge_costs = costs[edge]
    # Labelled by position, the entries' edges are their labels: no list of them made.
    entry_labels = edge if labels is None else labels[edge]
    return Graph(
        indptr.astype(np.int64), indices, weights[edge], entry_labels, edge_costs, cost_of
    )


def _check_edges(
    size: int,
    first: IntArray,
    second: IntArray,
    weights: FloatArray,
    labels: IntArray | None,
    keep: NDArray[np.bool_] | None,
) -> None:
    """Raise :func:`make_graph`'s ValueError for edge lists it cannot take."""
    shapes = {first.shape, second.shape, weights.shape}
    shapes |= set() if labels is None else {labels.shape}
    shapes |= set() if keep is None else {np.shape(keep)}
    if len(shapes) > 1:
        raise ValueError("`first`, `second`, `weights` and `labels` must have one length")
    if len(first) and (
        min(first.min(), second.min()) < 0 or max(first.max(), second.max()) >= size
    ):
        raise ValueError(f"`first` and `second` must be nodes of the graph, 0 to {size - 1}")
    if np.any(first == second):
        raise ValueError("a graph edge cannot join a node to itself")


@jit.kernel(cache=True, nogil=True)
def _component_labels(indptr: IntArray, indices: IntArray) -> IntArray:
    # Each unlabelled node in turn starts a component: labels in lowest-node order.
    size = len(indptr) - 1
    labels = np.full(size, -1, dtype=np.int64)
    stack = np.empty(max(size, 1), dtype=np.int64)
    label = 0
    for start in range(size):
        if labels[start] >= 0:
            continue
        labels[start] = label
        stack[0], depth = start, 1
        while depth:
            depth -= 1
            node = stack[depth]
            for slot in range(indptr[node], indptr[node + 1]):
                other = indices[slot]
                if labels[other] < 0:
                    labels[other] = label
                    stack[depth] = other
                    depth += 1
        label += 1
    return labels


def symmetric_rows(
    size: int,
    first: ArrayLike,
    second: ArrayLike,
    rows: NDArray[np.bool_] | None = None,
    keep: NDArray[np.bool_] | None = None,
) -> tuple[IntArray, IntArray, IntArray]:
    """Compressed sparse rows of undirected pairs, each pair entered from both of its ends.

    In linear time when the pairs come as neighbour pairs do (first < second,
    sorted by first then second); sorted first otherwise.

    Parameters
    ----------
    size : int
        N, the number of nodes.
    first, second : (E,) array_like of int
        The two ends of each pair, each pair once, no node paired with itself.
    rows : (N,) array of bool, optional
        Lay out only these nodes' rows; the others are empty. Default: every row.
    keep : (E,) array of bool, optional
        Enter only these pairs; the rest are left out as if not given, without
        a copy of the kept ones (a display's graph of tens of millions of
        entries out of a longer list). Default: every pair.

    Returns
    -------
    indptr : (N + 1,) ndarray of int
        Row v's entries are ``indptr[v]:indptr[v + 1]``.
    indices : (R,) ndarray of int
        Each entry's other end; each row sorted.
    edge : (R,) ndarray of int
        The pair (index into ``first``, kept or not) of each entry.

    Examples
    --------
    >>> from swazure_ros.core.graph import symmetric_rows
    >>> indptr, indices, edge = symmetric_rows(3, [0, 1], [1, 2])
    >>> indptr.tolist(), indices.tolist(), edge.tolist()
    ([0, 1, 3, 4], [1, 0, 2, 1], [0, 0, 1, 1])
    """
    # Contiguous, so that one compiled signature serves every caller.
    first = np.ascontiguousarray(first, dtype=np.int64)
    second = np.ascontiguousarray(second, dtype=np.int64)
    laid = np.ones(size, dtype=bool) if rows is None else np.asarray(rows, dtype=bool)
    if _ordered(first, second):
        entered = np.ones(len(first), dtype=bool) if keep is None else np.asarray(keep, bool)
        return _symmetric_rows(size, first, second, laid, entered)
    # Not as neighbour pairs come: the kept pairs sorted first, low end first.
    kept = np.arange(len(first)) if keep is None else np.flatnonzero(keep)
    low, high = np.minimum(first[kept], second[kept]), np.maximum(first[kept], second[kept])
    order = np.argsort(low * size + high, kind="stable")
    low, high = np.ascontiguousarray(low[order]), np.ascontiguousarray(high[order])
    indptr, indices, edge = _symmetric_rows(size, low, high, laid, np.ones(len(low), bool))
    return indptr, indices, kept[order[edge]]


@jit.kernel(cache=True, nogil=True)
def _ordered(first: IntArray, second: IntArray) -> bool:
    """Whether every pair has first < second and the pairs rise by (first, second)."""
    for e in range(len(first)):
        if first[e] >= second[e]:
            return False
        if e and (
            first[e] < first[e - 1] or (first[e] == first[e - 1] and second[e] <= second[e - 1])
        ):
            return False
    return True


@jit.kernel(cache=True, nogil=True)
def _symmetric_rows(
    size: int, first: IntArray, second: IntArray, rows: NDArray[np.bool_], keep: NDArray[np.bool_]
) -> tuple[IntArray, IntArray, IntArray]:
    """CSR rows (sorted) of the undirected edges first[e] < second[e] that ``keep`` marks,
    given sorted by (first, second), of the nodes ``rows`` marks: indptr, indices, and the
    edge e of each entry."""
    indptr = np.zeros(size + 1, dtype=np.int64)
    for e in range(len(first)):
        if not keep[e]:
            continue
        if rows[first[e]]:
            indptr[first[e] + 1] += 1
        if rows[second[e]]:
            indptr[second[e] + 1] += 1
    for node in range(size):
        indptr[node + 1] += indptr[node]
    cursor = indptr[:-1].copy()
    indices = np.empty(indptr[size], dtype=np.int64)
    edge = np.empty(indptr[size], dtype=np.int64)
    # Row v holds its smaller neighbours (edges where v is second, in order of first),
    # then its larger ones (where v is first, already in order of second).
    for e in range(len(first)):
        if keep[e] and rows[second[e]]:
            slot = cursor[second[e]]
            indices[slot], edge[slot] = first[e], e
            cursor[second[e]] += 1
    for e in range(len(first)):
        if keep[e] and rows[first[e]]:
            slot = cursor[first[e]]
            indices[slot], edge[slot] = second[e], e
            cursor[first[e]] += 1
    return indptr, indices, edge


@jit.kernel(cache=True, parallel=True)
def _edge_positions(
    indptr: IntArray, indices: IntArray, first: IntArray, second: IntArray
) -> IntArray:
    out = np.full(len(first), -1, dtype=np.int64)
    for m in jit.prange(len(first)):
        row = indices[indptr[first[m]] : indptr[first[m] + 1]]
        position = np.searchsorted(row, second[m])
        if position < len(row) and row[position] == second[m]:
            out[m] = indptr[first[m]] + position
    return out
