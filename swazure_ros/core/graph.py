"""Neighbour graphs: undirected graphs over FLS indices in CSR form (spec, section 4).

A :class:`Graph`'s edge length is the tracking distance of its pair, cm, and
each edge may carry a cost (its expected error, for the least-error policy)
and a label (the caller's index of its pair). :func:`make_graph` builds one
from edge lists; :mod:`.paths` searches it.

A graph whose edges range from near to far (SD_vis: 6 to 30 cm under the
published sensor) may lay each row out in bands of length, shortest first,
each band sorted by neighbour: a search bounded by its targets' cost then
skips the bands it cannot afford instead of reading every entry of a row
(docs/core.md, "Why it is fast").
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray


@dataclass(frozen=True)
class Graph:
    """An undirected graph in CSR form: neighbours of node v are indices[indptr[v]:indptr[v+1]].

    A row is laid out in B bands of edge length, shortest first, and each band
    is sorted by neighbour: entries ``bands[v, b]:bands[v, b + 1]`` of row v
    are its band b. Most graphs have one band, the row.

    An edge's cost (its expected error, which the least-error policy sums) is
    given, or computed from its weight by ``cost_of`` when first asked for
    (:meth:`edge_costs`): a display's graphs hold tens of millions of entries,
    and only that policy reads them.
    """

    indptr: IntArray  # (N + 1,)
    indices: IntArray  # (2E,), sorted within each band of a row
    weights: FloatArray  # (2E,), tracking distance of each edge, cm
    labels: NDArray[np.int32] | IntArray  # (2E,), each edge's label (its pair), 32 bits if all fit
    costs: FloatArray | None = None  # (2E,), expected error of each edge (least-error)
    # Elementwise from weights to costs (2E,) -> (2E,), for costs not given.
    cost_of: Callable[[FloatArray], FloatArray] | None = field(default=None, compare=False)
    # (N, B + 1): where each band of each row begins, and the row's end; None: one band.
    bands: IntArray | None = field(default=None, compare=False)
    # (N, 3): each node's place, cm, so that a search can skip the nodes too far from its
    # targets (:meth:`reach_ratio`); None: places unknown.
    positions: FloatArray | None = field(default=None, compare=False)
    _computed: dict[str, NDArray[Any]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def row_bands(self) -> IntArray:
        """Where each band of each row begins, and the row's end: (N, B + 1).

        Band b of row v is ``indices[row_bands()[v, b] : row_bands()[v, b + 1]]``;
        a graph of one band gives :meth:`whole_rows`.
        """
        return self.bands if self.bands is not None else self.whole_rows()

    def whole_rows(self) -> IntArray:
        """Each row as one band, whatever its layout: (N, 2), ``indptr``'s two columns."""
        if "whole rows" not in self._computed:
            self._computed["whole rows"] = np.stack([self.indptr[:-1], self.indptr[1:]], axis=1)
        return self._computed["whole rows"]

    def band_floors(self, costs: bool = False) -> FloatArray:
        """The least length (or, with ``costs``, cost) of an entry in each band: (B,).

        A search that cannot afford a band's floor skips the band. An empty
        band's floor is inf; computed once.

        Raises
        ------
        ValueError
            ``costs`` asked of a graph made without them.
        """
        key = "floors of costs" if costs else "floors of weights"
        if key not in self._computed:
            weights = self.edge_costs() if costs else self.weights
            if weights is None:
                raise ValueError("the graph was made without edge costs")
            self._computed[key] = _band_floors(self.row_bands(), weights)
        return self._computed[key]

    def reach_ratio(self, costs: bool = False, hops: bool = False) -> float:
        """The least length (cost, or hop) an entry has per cm of straight line between its ends.

        A path's summed lengths (costs, hops) are at least this times the
        distance between its ends, so a search can leave out a node whose cost
        plus this times its distance to the targets exceeds its bound. Zero
        for a graph without :attr:`positions` (nothing left out). Computed
        once for each kind.

        Parameters
        ----------
        costs : bool, optional
            Of the entries' costs (the least-error policy) instead of their lengths.
        hops : bool, optional
            Of their hops, one each (the fewest-hops policy).

        Raises
        ------
        ValueError
            ``costs`` asked of a graph made without them.
        """
        if self.positions is None:
            return 0.0
        key = "reach of hops" if hops else "reach of costs" if costs else "reach of weights"
        if key not in self._computed:
            weights = self.weights if hops else self.edge_costs() if costs else self.weights
            if weights is None:
                raise ValueError("the graph was made without edge costs")
            ratios = _least_per_length(self.indptr, self.indices, weights, self.positions, hops)
            least = float(ratios.min()) if len(ratios) else np.inf
            # Rounding of the ratio and of the distances a search computes is far below
            # 1e-9; a weight of 0 or less bounds nothing.
            useful = np.isfinite(least) and least > 0.0
            self._computed[key] = np.array(least * (1.0 - 1e-9) if useful else 0.0)
        return float(self._computed[key])

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
                self.row_bands(),
                self.indices,
                np.ascontiguousarray(first, dtype=np.int64),
                np.ascontiguousarray(second, dtype=np.int64),
            )
        )

    def edge_labels(self, first: ArrayLike, second: ArrayLike) -> IntArray:
        """Label of the edge first[m]-second[m] for each m: (M,); -1 where there is none."""
        position = self.edge_positions(first, second)
        return np.where(position >= 0, self.labels[position], -1).astype(np.int64, copy=False)

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
    bands: int = 1,
    positions: ArrayLike | None = None,
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
    bands : int, optional
        Lay each row out in this many bands of equal width between the
        shortest and the longest edge's weight, shortest first
        (:attr:`Graph.bands`); default one, the row.
    positions : (N, 3) array_like of float, cm, optional
        Each node's place, when an edge's weight grows with the distance
        between its ends' places (:meth:`Graph.reach_ratio`).

    Returns
    -------
    Graph
        Both directions of every edge, each band of a row sorted by neighbour;
        the ``weights``, ``labels`` and ``costs`` (2E,) follow the entries. The
        labels are held in 32 bits where every one fits (:func:`.csr.narrowed`).

    Raises
    ------
    ValueError
        The lists differ in length, an end is not a node, an edge joins a
        node to itself, ``bands`` is below one, or ``positions`` is not (N, 3).

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
    if bands < 1:
        raise ValueError(f"a graph's rows need one band at least, got {bands}")
    if positions is not None:
        positions = np.ascontiguousarray(positions, dtype=np.float64)
        if positions.shape != (size, 3):
            raise ValueError(f"`positions` must be ({size}, 3), got {positions.shape}")
    indptr, indices, edge = symmetric_rows(size, first, second, keep=keep)
    indptr = indptr.astype(np.int64)
    band_starts = _banded_rows(indptr, indices, edge, weights, bands) if bands > 1 else None
    edge_costs = None
    if costs is not None:
        costs = np.asarray(costs, dtype=np.float64)
        if costs.shape != weights.shape:
            raise ValueError("`costs` must have one value per edge")
        edge_costs = costs[edge]
    # Labelled by position, the entries' edges are their labels: no list of them made.
    # Held as long as the graph: in 32 bits where they fit (a display's graph in sight has
    # 14 M entries, 115 MB of labels in 64 bits).
    entry_labels = csr.narrowed(edge if labels is None else labels[edge])
    return Graph(
        indptr, indices, weights[edge], entry_labels, edge_costs, cost_of, band_starts, positions
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


@jit.kernel(cache=True, parallel=True)
def _least_per_length(
    indptr: IntArray, indices: IntArray, weights: FloatArray, positions: FloatArray, hops: bool
) -> FloatArray:
    """Each row's least weight (or, with ``hops``, 1) per unit of its entries' straight
    lengths: (N,); inf for a row without an entry of positive length."""
    size = len(indptr) - 1
    least = np.full(size, np.inf)
    for node in jit.prange(size):
        for entry in range(indptr[node], indptr[node + 1]):
            other = indices[entry]
            dx = positions[node, 0] - positions[other, 0]
            dy = positions[node, 1] - positions[other, 1]
            dz = positions[node, 2] - positions[other, 2]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            if length > 0.0:
                weight = 1.0 if hops else weights[entry]
                least[node] = min(least[node], weight / length)
    return least


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
    edges: bool = True,
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
    edges : bool, default True
        Whether to find each entry's pair. Without, ``edge`` is empty and the rows
        take a third less memory at their peak (a display's 20 M ordered blind
        pairs: 160 MB less).

    Returns
    -------
    indptr : (N + 1,) ndarray of int
        Row v's entries are ``indptr[v]:indptr[v + 1]``.
    indices : (R,) ndarray of int
        Each entry's other end; each row sorted.
    edge : (R,) ndarray of int
        The pair (index into ``first``, kept or not) of each entry; empty without
        ``edges``.

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
        return _symmetric_rows(size, first, second, laid, entered, edges)
    # Not as neighbour pairs come: the kept pairs sorted first, low end first.
    kept = np.arange(len(first)) if keep is None else np.flatnonzero(keep)
    low, high = np.minimum(first[kept], second[kept]), np.maximum(first[kept], second[kept])
    order = np.argsort(low * size + high, kind="stable")
    low, high = np.ascontiguousarray(low[order]), np.ascontiguousarray(high[order])
    indptr, indices, edge = _symmetric_rows(size, low, high, laid, np.ones(len(low), bool), edges)
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
    size: int,
    first: IntArray,
    second: IntArray,
    rows: NDArray[np.bool_],
    keep: NDArray[np.bool_],
    edges: bool,
) -> tuple[IntArray, IntArray, IntArray]:
    """CSR rows (sorted) of the undirected edges first[e] < second[e] that ``keep`` marks,
    given sorted by (first, second), of the nodes ``rows`` marks: indptr, indices, and,
    with ``edges``, the edge e of each entry (else none)."""
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
    edge = np.empty(indptr[size] if edges else 0, dtype=np.int64)
    # Row v holds its smaller neighbours (edges where v is second, in order of first),
    # then its larger ones (where v is first, already in order of second).
    for e in range(len(first)):
        if keep[e] and rows[second[e]]:
            slot = cursor[second[e]]
            indices[slot] = first[e]
            if edges:
                edge[slot] = e
            cursor[second[e]] += 1
    for e in range(len(first)):
        if keep[e] and rows[first[e]]:
            slot = cursor[first[e]]
            indices[slot] = second[e]
            if edges:
                edge[slot] = e
            cursor[first[e]] += 1
    return indptr, indices, edge


@jit.kernel(cache=True, parallel=True)
def _edge_positions(
    bands: IntArray, indices: IntArray, first: IntArray, second: IntArray
) -> IntArray:
    out = np.empty(len(first), dtype=np.int64)
    for m in jit.prange(len(first)):
        out[m] = entry_of(bands, indices, first[m], second[m])
    return out


@jit.kernel(cache=True, nogil=True)
def entry_of(bands: IntArray, indices: IntArray, node: int, other: int) -> int:
    """Where in ``indices`` row ``node`` holds ``other``: -1 where it does not.

    Each band of a row is sorted by neighbour (:class:`Graph`): a bisection in each.

    Parameters
    ----------
    bands : (N, B + 1) ndarray of int
        Where each band of each row begins, and the row's end (:meth:`Graph.row_bands`).
    indices : (2E,) ndarray of int
        The graph's entries.
    node, other : int
        The row, and the neighbour looked for in it.

    Returns
    -------
    int
        The entry's position, or -1.
    """
    for band in range(bands.shape[1] - 1):
        start = bands[node, band]
        row = indices[start : bands[node, band + 1]]
        position = np.searchsorted(row, other)
        if position < len(row) and row[position] == other:
            return int(start + position)
    return -1


@jit.kernel(cache=True, nogil=True)
def _banded_rows(
    indptr: IntArray, indices: IntArray, edge: IntArray, weights: FloatArray, bands: int
) -> IntArray:
    """Lay each row of ``indices`` and ``edge`` (sorted by neighbour) out in ``bands`` bands
    of equal width of ``weights[edge]``, in place, each band in neighbour order; return
    where each band of each row begins, and the row's end: (N, bands + 1)."""
    size = len(indptr) - 1
    shortest, longest = np.inf, -np.inf
    for entry in range(len(edge)):
        shortest = min(shortest, weights[edge[entry]])
        longest = max(longest, weights[edge[entry]])
    width = (longest - shortest) / bands
    starts = np.empty((size, bands + 1), dtype=np.int64)
    widest = 0
    for node in range(size):
        widest = max(widest, indptr[node + 1] - indptr[node])
    row_indices = np.empty(widest, dtype=indices.dtype)
    row_edge = np.empty(widest, dtype=np.int64)
    row_band = np.empty(widest, dtype=np.int64)
    cursor = np.empty(bands, dtype=np.int64)
    for node in range(size):
        begin, end = indptr[node], indptr[node + 1]
        cursor[:] = 0
        for entry in range(begin, end):
            band = 0
            if width > 0:
                band = min(int((weights[edge[entry]] - shortest) / width), bands - 1)
            row_indices[entry - begin] = indices[entry]
            row_edge[entry - begin] = edge[entry]
            row_band[entry - begin] = band
            cursor[band] += 1
        # Counts to starts, then each entry to the next place of its band: stable.
        place = begin
        for band in range(bands):
            starts[node, band] = place
            place, cursor[band] = place + cursor[band], place
        starts[node, bands] = end
        for offset in range(end - begin):
            band = row_band[offset]
            indices[cursor[band]] = row_indices[offset]
            edge[cursor[band]] = row_edge[offset]
            cursor[band] += 1
    return starts


@jit.kernel(cache=True, nogil=True)
def _band_floors(bands: IntArray, weights: FloatArray) -> FloatArray:
    """The least of ``weights`` in each band of every row: (B,), inf where none."""
    floors = np.full(bands.shape[1] - 1, np.inf)
    for node in range(bands.shape[0]):
        for band in range(bands.shape[1] - 1):
            for entry in range(bands[node, band], bands[node, band + 1]):
                floors[band] = min(floors[band], weights[entry])
    return floors
