"""Many paths in one record: :class:`Paths`, and what is read from it and made of it.

Path m of a :class:`Paths` is ``nodes[offsets[m]:offsets[m + 1]]``, FLS
indices from its source to its target, both included: the flat (CSR)
layout that :func:`~.paths.shortest_paths` returns and the evaluation keeps,
with no Python object per path. :func:`path_hops` lists every hop,
:func:`path_sums` sums an edge value along each path, :func:`merge_paths`
takes each pair's path from one of two records and :func:`paths_from_rows`
builds one from {pair: nodes}.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray
from .graph import Graph


@dataclass(frozen=True)
class Paths:
    """Paths for M (source, target) pairs; path m is nodes[offsets[m]:offsets[m + 1]]."""

    found: NDArray[np.bool_]  # (M,)
    hops: IntArray  # (M,), 0 where not found
    length: FloatArray  # (M,), sum of edge lengths, cm; nan where not found
    offsets: IntArray  # (M + 1,)
    nodes: IntArray  # from source to target, both included

    def path(self, pair: int) -> list[int]:
        """Nodes of path ``pair`` from source to target; [] where none was found."""
        return [int(node) for node in self.nodes[self.offsets[pair] : self.offsets[pair + 1]]]

    def take(self, pairs: IntArray) -> Paths:
        """The paths of ``pairs`` (K,), indices in any order, as a record of their own."""
        offsets, nodes = csr.take(self.offsets, self.nodes, pairs)
        return Paths(self.found[pairs], self.hops[pairs], self.length[pairs], offsets, nodes)

    def span(self, low: int, high: int) -> Paths:
        """The paths of pairs ``low`` .. ``high - 1``: views, not copies."""
        offsets, nodes = csr.span(self.offsets, self.nodes, low, high)
        return Paths(
            self.found[low:high], self.hops[low:high], self.length[low:high], offsets, nodes
        )


def paths_from_rows(
    size: int, rows: dict[int, list[int]], lengths: dict[int, float] | None = None
) -> Paths:
    """Paths of ``size`` pairs from {pair: nodes}; pairs without a row have none.

    Parameters
    ----------
    size : int
        M, the number of pairs.
    rows : dict of int to list of int
        {pair: its path's nodes, source first, target last}, FLS indices.
    lengths : dict of int to float, cm, optional
        {pair: its path's length}.

    Returns
    -------
    Paths
        M paths; a length is NaN where ``lengths`` does not give it.

    Examples
    --------
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> paths = paths_from_rows(3, {0: [4, 2, 7], 2: [1, 5]}, {0: 3.5})
    >>> paths.found.tolist(), paths.hops.tolist(), paths.path(0), paths.path(1)
    ([True, False, True], [2, 0, 1], [4, 2, 7], [])
    >>> paths.length.tolist()
    [3.5, nan, nan]
    """
    found = np.zeros(size, dtype=bool)
    hops = np.zeros(size, dtype=np.int64)
    length = np.full(size, np.nan)
    counts = np.zeros(size, dtype=np.int64)
    for pair, nodes in rows.items():
        found[pair], hops[pair], counts[pair] = True, len(nodes) - 1, len(nodes)
    for pair, value in (lengths or {}).items():
        length[pair] = value
    offsets = csr.offsets(counts)
    flat = np.empty(offsets[-1], dtype=np.int64)
    for pair, nodes in rows.items():
        flat[offsets[pair] : offsets[pair + 1]] = nodes
    return Paths(found, hops, length, offsets, flat)


def path_sums(graph: Graph, paths: Paths, values: FloatArray) -> FloatArray:
    """Sum of a value of each edge of ``graph`` along each path.

    Summed from the source outwards, as a search and the distributed
    protocol sum them, so that equal paths give equal floats.

    Parameters
    ----------
    graph : Graph
        Holds every hop of ``paths`` as an edge.
    paths : Paths
        M paths over ``graph``'s nodes.
    values : (2E,) ndarray of float
        One value per entry of ``graph.indices`` (``graph.weights``, cm, or
        ``graph.costs``, cm).

    Returns
    -------
    (M,) ndarray of float
        Each path's sum; NaN where a pair has no path.

    Examples
    --------
    >>> from swazure_ros.core.graph import make_graph
    >>> from swazure_ros.core.path_arrays import path_sums, paths_from_rows
    >>> graph = make_graph(3, [0, 1], [1, 2], [1.5, 2.0])
    >>> path_sums(graph, paths_from_rows(2, {0: [0, 1, 2]}), graph.weights).tolist()
    [3.5, nan]
    """
    pair, start, end = path_hops(paths)
    # bincount adds in array order, and path_hops lists each path's hops in order.
    sums = np.bincount(
        pair, weights=values[graph.edge_positions(start, end)], minlength=len(paths.found)
    )
    return np.where(paths.found, sums, np.nan)


def path_hops(paths: Paths) -> tuple[IntArray, IntArray, IntArray]:
    """Every hop of every path, path after path, each path's hops from its source on.

    Parameters
    ----------
    paths : Paths
        M paths with H hops in all.

    Returns
    -------
    pair : (H,) ndarray of int
        The path (0 to M - 1) of each hop.
    start, end : (H,) ndarray of int
        The FLS each hop leaves and the one it reaches.

    Examples
    --------
    >>> from swazure_ros.core.path_arrays import path_hops, paths_from_rows
    >>> pair, start, end = path_hops(paths_from_rows(2, {0: [4, 2, 7], 1: [1, 5]}))
    >>> pair.tolist(), start.tolist(), end.tolist()
    ([0, 0, 1], [4, 2, 1], [2, 7, 5])
    """
    offsets = np.asarray(paths.offsets, dtype=np.int64)
    hop_offsets = csr.offsets(np.maximum(np.diff(offsets) - 1, 0))
    return _path_hops(offsets, np.asarray(paths.nodes, dtype=np.int64), hop_offsets)


@jit.kernel(cache=True, parallel=True)
def _path_hops(
    offsets: IntArray, nodes: IntArray, hop_offsets: IntArray
) -> tuple[IntArray, IntArray, IntArray]:
    hops = hop_offsets[-1]
    pair = np.empty(hops, dtype=np.int64)
    start = np.empty(hops, dtype=np.int64)
    end = np.empty(hops, dtype=np.int64)
    for path in jit.prange(len(offsets) - 1):
        first = offsets[path]
        for hop in range(hop_offsets[path], hop_offsets[path + 1]):
            at = first + hop - hop_offsets[path]
            pair[hop], start[hop], end[hop] = path, nodes[at], nodes[at + 1]
    return pair, start, end


def merge_paths(first: Paths, second: Paths, use_second: NDArray[np.bool_]) -> Paths:
    """Paths taking pair m from ``second`` where ``use_second[m]``, else from ``first``.

    Parameters
    ----------
    first : Paths
        M paths.
    second : Paths
        K paths: those of the pairs where ``use_second`` holds, in order.
    use_second : (M,) ndarray of bool
        True at K pairs.

    Returns
    -------
    Paths
        M paths.

    Raises
    ------
    ValueError
        ``second`` does not hold one path per pair where ``use_second`` holds.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.path_arrays import merge_paths, paths_from_rows
    >>> first = paths_from_rows(2, {0: [0, 1]})
    >>> second = paths_from_rows(1, {0: [2, 3, 4]})
    >>> merged = merge_paths(first, second, np.array([False, True]))
    >>> merged.path(0), merged.path(1)
    ([0, 1], [2, 3, 4])
    """
    if len(use_second) != len(first.found):
        raise ValueError("`use_second` must have one value per pair of `first`")
    if len(second.found) != int(use_second.sum()) or len(second.offsets) != len(second.found) + 1:
        raise ValueError("`second` must hold exactly the pairs where `use_second` holds")
    found = first.found.copy()
    hops = first.hops.copy()
    length = first.length.copy()
    found[use_second] = second.found
    hops[use_second] = second.hops
    length[use_second] = second.length
    counts = np.where(found, hops + 1, 0)
    offsets = csr.offsets(counts)
    nodes = np.empty(offsets[-1], dtype=np.int64)
    row_in_second = np.cumsum(use_second) - 1
    _merge_nodes(
        first.offsets, first.nodes, second.offsets, second.nodes, use_second, row_in_second,
        offsets, nodes,
    )  # fmt: skip
    return Paths(found, hops, length, offsets, nodes)


@jit.kernel(cache=True, parallel=True)
def _merge_nodes(
    first_offsets: IntArray,
    first_nodes: IntArray,
    second_offsets: IntArray,
    second_nodes: IntArray,
    use_second: NDArray[np.bool_],
    row_in_second: IntArray,
    offsets: IntArray,
    nodes: IntArray,
) -> None:
    for pair in jit.prange(len(use_second)):
        if use_second[pair]:
            row = row_in_second[pair]
            begin, source = second_offsets[row], second_nodes
        else:
            begin, source = first_offsets[pair], first_nodes
        for slot in range(offsets[pair + 1] - offsets[pair]):
            nodes[offsets[pair] + slot] = source[begin + slot]
