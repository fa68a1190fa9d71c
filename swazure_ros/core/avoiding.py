"""Paths that avoid given FLSs: the policy's path between each pair that keeps clear of them.

:func:`avoiding_paths` is the family of :func:`.paths.shortest_paths` for paths
that must not enter given nodes: the node-disjoint paths of :mod:`.fusion`,
each of which avoids the inner FLSs of the paths found before it.

Each pair avoids nodes of its own, so one search could serve one pair. Most
of a pair's avoided nodes are far from its source, though, and the first of
them (a path's first hop) is a neighbour of it. Pairs of one source that
avoid the same neighbours of it share one search that avoids only those
(:func:`sharing`); a pair takes that search's path when the path enters
none of its own avoided nodes, and is searched alone otherwise. The shared
search's graph holds the pair's own (it avoids fewer nodes), so the shared
path is the pair's: no cost is lower in the pair's graph than in the shared
one, the path's nodes keep theirs, and each of its predecessors, the least
index of a larger set of ties, is the least of the pair's too. The paths,
lengths and ties are those of one search per pair (tested).
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import IntArray
from .graph import Graph
from .path_arrays import Paths, path_sums
from .paths import _check_nodes, _compress, _search_of
from .search import Search, fresh_labels, reset_labels, search_from, walk_back

#: Longest path, in nodes, that :func:`avoiding_paths` returns.
AVOIDING_WIDTH = 64

#: Fewest pairs a shared search is made for; a smaller group's pairs are searched alone. A
#: search for many targets cannot bound itself by one target's place and neighbours, so it
#: labels more: on the race car's fusion (a sixth of its sources) a group of 8 or more
#: paid, one of 1 to 3 cost more than its pairs' own searches (BENCHMARKS.md, "Pairs that
#: avoid the same first hops share a search").
SHARED_LEAST = 8


class Sharing(NamedTuple):
    """Pairs grouped by the search they share (:func:`sharing`).

    ``order[starts[g]:starts[g + 1]]`` are group g's pairs; the group searches
    from its pairs' source, avoiding ``shared[g]``'s nodes (-1: none). Pairs
    that no group takes (their avoided nodes hold their own source or target,
    they are their own target, or their group would be too small) are ``alone``.
    """

    order: IntArray  # (P,), pairs taken by a group, group after group
    starts: IntArray  # (G + 1,)
    shared: IntArray  # (G, K), each group's avoided nodes, -1 past them
    alone: IntArray  # (M - P,), pairs searched one by one


def avoiding_paths(
    graph: Graph,
    sources: ArrayLike,
    targets: ArrayLike,
    policy: str,
    avoid_offsets: ArrayLike,
    avoid: ArrayLike,
    components: IntArray | None = None,
) -> Paths:
    """The policy's path between each pair of FLSs that enters none of the pair's avoided nodes.

    The pairs in any order: the family of :func:`.paths.shortest_paths` for
    paths that must keep clear of given FLSs (node-disjoint paths,
    :mod:`.fusion`). Pairs that avoid the same neighbours of one source share
    a search (the module's text; groups of :data:`SHARED_LEAST` or more); the
    paths are those of a search per pair.

    Parameters
    ----------
    graph : Graph
        The neighbour graph the paths run in.
    sources, targets : (M,) array_like of int
        Pairs of nodes.
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        The path policy (:func:`.paths.shortest_paths`).
    avoid_offsets : (M + 1,) array_like of int
        Pair m avoids ``avoid[avoid_offsets[m]:avoid_offsets[m + 1]]``.
    avoid : (A,) array_like of int
        The avoided nodes, pair after pair.
    components : (N,) ndarray of int, optional
        ``graph.components()``, when the caller has it already.

    Returns
    -------
    Paths
        The path of each pair, source first, with its tracking distance,
        cm; a path longer than :data:`AVOIDING_WIDTH` nodes counts as not
        found.

    Raises
    ------
    ValueError
        An unknown policy, least-error without edge costs, pairs of unequal
        lengths or that are not nodes of ``graph``, or ``avoid_offsets`` that
        do not split ``avoid`` into M rows of nodes.

    Examples
    --------
    >>> from swazure_ros.core.graph import make_graph
    >>> from swazure_ros.core.avoiding import avoiding_paths
    >>> square = make_graph(4, [0, 1, 2, 0], [1, 2, 3, 3], [1.0, 1.0, 1.0, 5.0])
    >>> avoiding_paths(square, [0], [2], "shortest-length", [0, 1], [1]).path(0)
    [0, 3, 2]
    """
    search = _search_of(graph, policy, components)
    sources = np.ascontiguousarray(sources, dtype=np.int64)
    targets = np.ascontiguousarray(targets, dtype=np.int64)
    avoid_offsets = np.ascontiguousarray(avoid_offsets, dtype=np.int64)
    avoid = np.ascontiguousarray(avoid, dtype=np.int64)
    _check_nodes(graph, sources, targets)
    _check_avoided(graph, len(sources), avoid_offsets, avoid)
    pairs = len(sources)
    found = np.zeros(pairs, dtype=np.bool_)
    hops = np.zeros(pairs, dtype=np.int64)
    buffer = np.full((pairs, AVOIDING_WIDTH), -1, dtype=np.int64)
    # The least group read here, not bound as a default: a test searches groups of one.
    groups = sharing(graph, sources, targets, avoid_offsets, avoid, SHARED_LEAST)
    threads = jit.get_num_threads()
    resolved = _shared_kernel(
        search, sources, targets, avoid_offsets, avoid, groups.order, groups.starts,
        groups.shared, AVOIDING_WIDTH, found, hops, buffer,
        max(1, min(len(groups.starts) - 1, 4 * threads)),
    )  # fmt: skip
    alone = np.concatenate([groups.alone, groups.order[~resolved]])
    _alone_kernel(
        search, sources, targets, avoid_offsets, avoid, np.sort(alone), AVOIDING_WIDTH,
        found, hops, buffer, max(1, min(len(alone), 4 * threads)),
    )  # fmt: skip
    counts = np.where(found, hops + 1, 0)
    offsets = csr.offsets(counts)
    nodes = np.empty(offsets[-1], dtype=np.int64)
    _compress(buffer, counts, offsets, nodes)
    paths = Paths(found, hops, np.full(pairs, np.nan), offsets, nodes)
    return replace(paths, length=path_sums(graph, paths, graph.weights))


def sharing(
    graph: Graph,
    sources: IntArray,
    targets: IntArray,
    avoid_offsets: IntArray,
    avoid: IntArray,
    least: int = SHARED_LEAST,
) -> Sharing:
    """Pairs grouped by source and by the neighbours of it they avoid: a search for each group.

    Parameters
    ----------
    graph : Graph
        The neighbour graph.
    sources, targets : (M,) ndarray of int
        Pairs of nodes.
    avoid_offsets : (M + 1,) ndarray of int
        Pair m avoids ``avoid[avoid_offsets[m]:avoid_offsets[m + 1]]``.
    avoid : (A,) ndarray of int
        The avoided nodes, pair after pair.
    least : int, optional
        Fewest pairs of a group; the pairs of smaller ones are searched alone.

    Returns
    -------
    Sharing
        Groups in order of source, then of their avoided neighbours (sorted,
        compared column by column); a group's pairs in input order.
    """
    counts = np.diff(avoid_offsets)
    rows = np.repeat(np.arange(len(sources), dtype=np.int64), counts)
    # A pair that avoids its own source or target, or is its own target: searched alone,
    # as before, so that what such a search does with them stays its own.
    alone = np.zeros(len(sources), dtype=bool)
    alone[rows[(avoid == sources[rows]) | (avoid == targets[rows])]] = True
    alone |= sources == targets
    near = graph.edge_positions(sources[rows], avoid) >= 0
    rows, nodes = rows[near], avoid[near]
    by_pair = np.lexsort((nodes, rows))
    rows, nodes = rows[by_pair], nodes[by_pair]
    near_counts = np.bincount(rows, minlength=len(sources))
    width = max(1, int(near_counts.max(initial=0)))
    keys = np.full((len(sources), width), -1, dtype=np.int64)
    keys[rows, np.arange(len(rows)) - csr.offsets(near_counts)[rows]] = nodes
    taken = np.flatnonzero(~alone)
    taken_keys = keys[taken]
    by_key = np.lexsort((*taken_keys.T[::-1], sources[taken]))
    order = taken[by_key]
    change = np.ones(len(order), dtype=bool)
    change[1:] = sources[order[1:]] != sources[order[:-1]]
    for column in taken_keys.T:  # a column at a time: a fusion block's pairs are millions
        ordered = column[by_key]
        change[1:] |= ordered[1:] != ordered[:-1]
    firsts = np.flatnonzero(change)
    sizes = np.diff(np.append(firsts, len(order)))
    large = np.repeat(sizes >= least, sizes)
    alone[order[~large]] = True
    order, starts = order[large], csr.offsets(sizes[sizes >= least])
    return Sharing(order, starts, keys[order[starts[:-1]]], np.flatnonzero(alone))


def _check_avoided(graph: Graph, pairs: int, avoid_offsets: IntArray, avoid: IntArray) -> None:
    """Raise ValueError unless ``avoid_offsets`` split ``avoid`` into ``pairs`` rows of nodes."""
    if avoid_offsets.shape != (pairs + 1,) or avoid.ndim != 1:
        raise ValueError(f"`avoid_offsets` must hold {pairs + 1} offsets into `avoid`")
    rising = np.all(np.diff(avoid_offsets) >= 0)
    if avoid_offsets[0] != 0 or avoid_offsets[-1] != len(avoid) or not rising:
        raise ValueError("`avoid_offsets` must rise from 0 to the length of `avoid`")
    if len(avoid) and (avoid.min() < 0 or avoid.max() >= graph.size):
        raise ValueError("`avoid` must hold nodes of the graph")


@jit.kernel(cache=True, parallel=True)
def _shared_kernel(
    search: Search, sources: IntArray, targets: IntArray, avoid_offsets: IntArray,
    avoid: IntArray, order: IntArray, starts: IntArray, shared: IntArray, width: int,
    found: NDArray[np.bool_], hops: IntArray, buffer: IntArray, chunks: int,
) -> NDArray[np.bool_]:  # fmt: skip
    """Search once for each group of :func:`sharing`; each of its pairs whose path there
    enters none of its own avoided nodes (or that has none) takes it into ``found``, ``hops``
    and ``buffer``. Returns, by position in ``order``, which pairs were settled so."""
    fewest_hops = search.fewest_hops
    size = len(search.indptr) - 1
    groups = len(starts) - 1
    resolved = np.zeros(len(order), dtype=np.bool_)
    most = 0
    for group in range(groups):
        most = max(most, starts[group + 1] - starts[group])
    for chunk in jit.prange(chunks):
        labels = fresh_labels(size)
        primary, secondary, pred, settled, wanted, _, _, _ = labels
        wanted_targets = np.empty(most, dtype=np.int64)
        for group in range(chunk, groups, chunks):
            low, high = starts[group], starts[group + 1]
            source = sources[order[low]]
            for node in shared[group]:
                if node >= 0:
                    settled[node] = True  # avoided: the search never enters it
            for at in range(low, high):
                wanted_targets[at - low] = targets[order[at]]
            count = search_from(search, source, wanted_targets[: high - low], labels)
            for at in range(low, high):
                pair = order[at]
                target = targets[pair]
                if primary[target] == np.inf:
                    resolved[at] = True  # unreachable avoiding less: unreachable
                    continue
                if not settled[target]:
                    continue
                steps = int(primary[target] if fewest_hops else secondary[target])
                if steps + 1 > width:
                    continue
                row = buffer[pair]
                walk_back(pred, target, steps, row)
                own = avoid[avoid_offsets[pair] : avoid_offsets[pair + 1]]
                if _enters(row[: steps + 1], own):
                    row[: steps + 1] = -1
                    continue
                resolved[at], found[pair], hops[pair] = True, True, steps
            reset_labels(labels, count)
            for node in shared[group]:
                if node >= 0:
                    settled[node] = False
            wanted[wanted_targets[: high - low]] = False
    return resolved


@jit.kernel(cache=True, nogil=True)
def _enters(path: IntArray, nodes: IntArray) -> bool:
    """Whether ``path`` holds any of ``nodes`` (a few: a scan)."""
    for node in path:
        for avoided in nodes:
            if node == avoided:
                return True
    return False


@jit.kernel(cache=True, parallel=True)
def _alone_kernel(
    search: Search, sources: IntArray, targets: IntArray, avoid_offsets: IntArray,
    avoid: IntArray, which: IntArray, width: int, found: NDArray[np.bool_], hops: IntArray,
    buffer: IntArray, chunks: int,
) -> None:  # fmt: skip
    """A search of its own for each pair of ``which``, into ``found``, ``hops``, ``buffer``."""
    fewest_hops = search.fewest_hops
    size = len(search.indptr) - 1
    for chunk in jit.prange(chunks):
        labels = fresh_labels(size)
        primary, secondary, pred, settled, wanted, _, _, _ = labels
        one = np.empty(1, dtype=np.int64)
        for at in range(chunk, len(which), chunks):
            pair = which[at]
            source, target = sources[pair], targets[pair]
            # An avoided node counts as settled: the search never enters it.
            blocked = avoid[avoid_offsets[pair] : avoid_offsets[pair + 1]]
            settled[blocked] = True
            one[0] = target
            count = search_from(search, source, one, labels)
            if target != source and primary[target] < np.inf and settled[target]:
                steps = int(primary[target] if fewest_hops else secondary[target])
                if steps + 1 <= width:
                    found[pair] = True
                    hops[pair] = steps
                    walk_back(pred, target, steps, buffer[pair])
            reset_labels(labels, count)
            settled[blocked] = False
            wanted[target] = False
