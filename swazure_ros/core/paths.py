"""Path policies: the path each policy picks between many pairs at once (spec, section 5).

:func:`shortest_paths` finds, for many (source, target) pairs of a
:class:`~.graph.Graph` at once, the path the policy picks:

- ``fewest-hops``: fewest edges; among those, the smallest length;
- ``shortest-length``: smallest sum of tracking distances; among those, the
  fewest edges;
- ``least-error``: smallest sum of the edges' expected errors
  (:meth:`~.graph.Graph.edge_costs`, from :func:`~.hop_errors.hop_error`); among
  those, the fewest edges. Derived in docs/core.md ("Least-error paths").

Remaining ties are broken by predecessor: the predecessor of a node on the
path is the neighbour with the smallest FLS index among those through which
the node is reached at its optimal (primary, secondary) cost. The rule
depends only on the cost labels, not on the order of exploration, so any
correct search (a distributed one included) picks the same path.
:func:`.avoiding.avoiding_paths` finds the policy's path that avoids given
nodes. Both run the one-source search of :mod:`.search` from many sources in
parallel and return :class:`~.path_arrays.Paths`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray
from .graph import Graph
from .path_arrays import Paths, path_sums
from .search import Search, fresh_labels, reset_labels, search_from, walk_back

FEWEST_HOPS = "fewest-hops"
SHORTEST_LENGTH = "shortest-length"
LEAST_ERROR = "least-error"
POLICIES = (FEWEST_HOPS, SHORTEST_LENGTH, LEAST_ERROR)

#: Path nodes kept per pair in the parallel pass; longer paths take a second pass.
_WIDTH = 8


#: Most buckets a search keeps in turn; edges more unequal than this are searched with a heap.
_MOST_BUCKETS = 4096


def check_policy(policy: str) -> str:
    """The path policy ``policy`` names, checked.

    Parameters
    ----------
    policy : str
        One of :data:`POLICIES`.

    Returns
    -------
    str
        ``policy``.

    Raises
    ------
    ValueError
        ``policy`` names no path policy; the message lists them.

    Examples
    --------
    >>> from swazure_ros.core.paths import check_policy
    >>> check_policy("fewest-hops")
    'fewest-hops'
    >>> check_policy("straightest")
    Traceback (most recent call last):
    ...
    ValueError: unknown path policy 'straightest'; expected one of fewest-hops, ...
    """
    if policy not in POLICIES:
        raise ValueError(f"unknown path policy {policy!r}; expected one of {', '.join(POLICIES)}")
    return policy


def shortest_paths(
    graph: Graph,
    sources: ArrayLike,
    targets: ArrayLike,
    policy: str,
    components: IntArray | None = None,
    progress: Callable[[int], None] | None = None,
    batch: int = 512,
) -> Paths:
    """The policy's path between each pair of FLSs, for many pairs sorted by source.

    Each source is searched from once, whatever its number of targets; the
    sources are spread over the machine's threads.

    Parameters
    ----------
    graph : Graph
        The neighbour graph the paths run in.
    sources, targets : (M,) array_like of int
        Pairs of nodes, grouped by source (all pairs of one source adjacent,
        sources ascending).
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        The path policy (the module's text); least-error needs
        ``graph.edge_costs()``.
    components : (N,) ndarray of int, optional
        ``graph.components()``, when the caller has it already.
    progress : callable, optional
        Called with the number of pairs done after each batch of sources.
    batch : int, optional
        Sources searched between two calls of ``progress``.

    Returns
    -------
    Paths
        The path of each pair, source first; ``length`` is its tracking
        distance, cm, whatever the policy summed. A pair whose target is its
        source, or that ``graph`` does not join, has none.

    Raises
    ------
    ValueError
        An unknown policy, least-error without edge costs, pairs of unequal
        lengths or that are not nodes of ``graph``, or pairs not sorted by
        source.

    Examples
    --------
    A square 0-1-2-3 whose side 0-3 is long: fewest-hops takes it,
    shortest-length goes round.

    >>> from swazure_ros.core.graph import make_graph
    >>> from swazure_ros.core.paths import shortest_paths
    >>> square = make_graph(4, [0, 1, 2, 0], [1, 2, 3, 3], [1.0, 1.0, 1.0, 5.0])
    >>> shortest_paths(square, [0], [3], "fewest-hops").path(0)
    [0, 3]
    >>> paths = shortest_paths(square, [0, 0], [2, 3], "shortest-length")
    >>> paths.path(0), paths.path(1), paths.length.tolist()
    ([0, 1, 2], [0, 1, 2, 3], [2.0, 3.0])
    """
    # Contiguous: a strided list (np.nonzero's of a matrix) would compile the kernels anew.
    sources = np.ascontiguousarray(sources, dtype=np.int64)
    targets = np.ascontiguousarray(targets, dtype=np.int64)
    search = _search_of(graph, policy, components)
    _check_pairs(graph, sources, targets)
    found, hops, length, buffer = _search_batches(search, sources, targets, progress, batch)
    counts = np.where(found, hops + 1, 0)
    offsets = csr.offsets(counts)
    nodes = np.empty(offsets[-1], dtype=np.int64)
    _compress(buffer, counts, offsets, nodes)  # long paths' rows are rewritten below
    if not (counts <= _WIDTH).all():
        _write_long_paths(search, sources, targets, hops, offsets, nodes)
    paths = Paths(found, hops, length, offsets, nodes)
    if policy == LEAST_ERROR:
        return replace(paths, length=path_sums(graph, paths, graph.weights))
    return paths


def _check_pairs(graph: Graph, sources: IntArray, targets: IntArray) -> None:
    """Raise ValueError unless the pairs (M,) are nodes of ``graph``, sorted by source."""
    _check_nodes(graph, sources, targets)
    if len(sources) > 1 and np.any(sources[1:] < sources[:-1]):
        raise ValueError("pairs must be sorted by source")


def _check_nodes(graph: Graph, sources: IntArray, targets: IntArray) -> None:
    """Raise ValueError unless ``sources`` and ``targets`` are (M,) nodes of ``graph``."""
    if sources.ndim != 1 or sources.shape != targets.shape:
        raise ValueError("`sources` and `targets` must be lists of one length")
    if len(sources) and (
        min(sources.min(), targets.min()) < 0 or max(sources.max(), targets.max()) >= graph.size
    ):
        raise ValueError("`sources` and `targets` must be nodes of the graph")


def _policy_weights(graph: Graph, policy: str) -> tuple[FloatArray, bool]:
    """The edge weights a search sums under ``policy`` (2E,), and whether hops come first."""
    # Least-error is shortest-length over the edges' costs instead of their lengths.
    if check_policy(policy) == LEAST_ERROR:
        costs = graph.edge_costs()
        if costs is None:
            raise ValueError("the least-error policy needs a graph with edge costs")
        return costs, False
    return graph.weights, policy == FEWEST_HOPS


def _buckets(weights: FloatArray, fewest_hops: bool) -> tuple[float, int]:
    """Bucket width and bucket count of a search summing ``weights`` (2E,); (0, 0) for a heap.

    The width is the smallest edge's, less a margin far above rounding, so
    that an edge always leads to a later bucket (see :func:`_search_buckets`).
    """
    if fewest_hops:  # the hop count comes first and grows by exactly 1
        smallest = largest = 1.0
    elif len(weights):
        smallest, largest = float(weights.min()), float(weights.max())
    else:
        return 0.0, 0
    if not smallest > 0:
        return 0.0, 0
    width = smallest * (1.0 - 1e-9)
    slots = int(largest / width) + 2
    return (width, slots) if slots <= _MOST_BUCKETS else (0.0, 0)


def _search_of(graph: Graph, policy: str, components: IntArray | None) -> Search:
    """The record the search kernels take for ``policy`` on ``graph``."""
    weights, fewest_hops = _policy_weights(graph, policy)
    if components is None:
        components = graph.components()
    # A band is skipped where its least weight is beyond a search's bound. Hops are
    # bounded on their own, so a fewest-hops search reads each row whole, as one band
    # (the order of a node's offers changes no label, nor any tie: search.py).
    bands = graph.whole_rows()
    floors = np.zeros(1)
    least_error = check_policy(policy) == LEAST_ERROR
    if graph.bands is not None and not fewest_hops:
        bands = graph.bands
        floors = graph.band_floors(costs=least_error)
    positions = graph.positions if graph.positions is not None else np.empty((0, 3))
    return Search(
        graph.indptr,
        graph.indices,
        weights,
        components,
        fewest_hops,
        *_buckets(weights, fewest_hops),
        bands,
        floors,
        positions,
        graph.reach_ratio(costs=least_error, hops=fewest_hops),
    )


def _search_batches(
    search: Search,
    sources: IntArray,
    targets: IntArray,
    progress: Callable[[int], None] | None,
    batch: int,
) -> SearchResults:
    """Each pair's result, searching from ``batch`` sources at a time; paths up to _WIDTH nodes."""
    pairs = len(sources)
    found = np.zeros(pairs, dtype=bool)
    hops = np.zeros(pairs, dtype=np.int64)
    length = np.full(pairs, np.nan)
    buffer = np.empty((pairs, _WIDTH), dtype=np.int64)
    unique, starts = np.unique(sources, return_index=True)
    target_ptr = np.append(starts, pairs).astype(np.int64)
    for begin in range(0, len(unique), batch):
        end = min(begin + batch, len(unique))
        lo, hi = target_ptr[begin], target_ptr[end]
        _search_kernel(
            search,
            unique[begin:end],
            target_ptr[begin : end + 1] - lo,
            targets[lo:hi],
            # Many chunks: the threads share sources of unequal cost evenly.
            min(end - begin, 16 * jit.get_num_threads()),
            SearchResults(found[lo:hi], hops[lo:hi], length[lo:hi], buffer[lo:hi]),
        )
        if progress is not None:
            progress(int(hi - lo))
    return SearchResults(found, hops, length, buffer)


def _write_long_paths(
    search: Search,
    sources: IntArray,
    targets: IntArray,
    hops: IntArray,
    offsets: IntArray,
    nodes: IntArray,
) -> None:
    """Write the paths longer than _WIDTH nodes into ``nodes`` at ``offsets``.

    A second search from each source with a long path, writing whole paths this time.
    """
    counts = np.diff(offsets)
    long_sources = np.unique(sources[counts > _WIDTH])
    again = np.flatnonzero(np.isin(sources, long_sources))
    _, starts = np.unique(sources[again], return_index=True)
    scratch = np.empty(int((hops[again] + 1).sum()) + 1, dtype=np.int64)
    scratch_offsets = csr.offsets(hops[again] + 1)[:-1]
    _long_paths(
        search,
        long_sources,
        np.append(starts, len(again)).astype(np.int64),
        targets[again],
        hops[again],
        _WIDTH,
        scratch_offsets,
        scratch,
    )
    for slot, pair in enumerate(again):
        if hops[pair] + 1 > _WIDTH:
            start = scratch_offsets[slot]
            nodes[offsets[pair] : offsets[pair + 1]] = scratch[start : start + hops[pair] + 1]


class SearchResults(NamedTuple):
    """What the searches found for each of M pairs, as :func:`_search_kernel` writes it."""

    found: NDArray[np.bool_]  # (M,)
    hops: IntArray  # (M,)
    length: FloatArray  # (M,), cm
    buffer: IntArray  # (M, W), a found path's first nodes, up to W


@jit.kernel(cache=True, parallel=True)
def _search_kernel(
    search: Search,
    sources: IntArray,
    target_ptr: IntArray,
    targets: IntArray,
    chunks: int,
    results: SearchResults,
) -> None:
    """Search from each source; write each pair's result into ``results``.

    The results come in unset (False, 0, NaN); a found path's first nodes,
    up to W, go into its row of ``results.buffer``.
    """
    found, hops, length, buffer = results
    fewest_hops = search.fewest_hops
    size = len(search.indptr) - 1
    width = buffer.shape[1]
    for chunk in jit.prange(chunks):
        labels = fresh_labels(size)
        primary, secondary, pred, settled, wanted, _, _, _ = labels
        for position in range(chunk, len(sources), chunks):
            source = sources[position]
            mine = targets[target_ptr[position] : target_ptr[position + 1]]
            count = search_from(search, source, mine, labels)
            for offset in range(len(mine)):
                pair = target_ptr[position] + offset
                target = mine[offset]
                if target == source or not settled[target]:
                    continue
                found[pair] = True
                steps = int(primary[target] if fewest_hops else secondary[target])
                hops[pair] = steps
                length[pair] = secondary[target] if fewest_hops else primary[target]
                if steps + 1 <= width:
                    walk_back(pred, target, steps, buffer[pair])
            reset_labels(labels, count)
            wanted[mine] = False


@jit.kernel(cache=True)
def _long_paths(
    search: Search,
    sources: IntArray,
    target_ptr: IntArray,
    targets: IntArray,
    hops: IntArray,
    width: int,
    offsets: IntArray,
    nodes: IntArray,
) -> None:
    """Write the paths longer than ``width`` nodes into ``nodes`` at ``offsets``."""
    labels = fresh_labels(len(search.indptr) - 1)
    for position in range(len(sources)):
        start, stop = target_ptr[position], target_ptr[position + 1]
        if np.all(hops[start:stop] + 1 <= width):
            continue
        count = search_from(search, sources[position], targets[start:stop], labels)
        for pair in range(start, stop):
            if hops[pair] + 1 > width:
                walk_back(labels.pred, targets[pair], hops[pair], nodes[offsets[pair] :])
        reset_labels(labels, count)
        labels.wanted[targets[start:stop]] = False


@jit.kernel(cache=True, parallel=True)
def _compress(buffer: IntArray, counts: IntArray, offsets: IntArray, nodes: IntArray) -> None:
    """Copy the first counts[m] nodes of row m of ``buffer`` (M, W) to nodes[offsets[m]:]."""
    for row in jit.prange(len(counts)):
        for column in range(min(counts[row], buffer.shape[1])):
            nodes[offsets[row] + column] = buffer[row, column]
