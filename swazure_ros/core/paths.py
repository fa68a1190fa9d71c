"""Neighbour graphs and path policies (spec, sections 4 and 5).

A :class:`Graph` is an undirected graph over FLS indices in CSR form whose
edge length is the tracking distance. :func:`shortest_paths` finds, for many
(source, target) pairs at once, the path the policy picks:

- ``fewest-hops``: fewest edges; among those, the smallest length;
- ``shortest-length``: smallest sum of tracking distances; among those, the
  fewest edges;
- ``least-error``: smallest sum of the edges' expected errors
  (:attr:`Graph.costs`, from :func:`~.sensor.hop_error`); among those, the
  fewest edges. Derived in docs/core.md ("Least-error paths").

Remaining ties are broken by predecessor: the predecessor of a node on the
path is the neighbour with the smallest FLS index among those through which
the node is reached at its optimal (primary, secondary) cost. The rule
depends only on the cost labels, not on the order of exploration, so any
correct search (a distributed one included) picks the same path.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray

FEWEST_HOPS = "fewest-hops"
SHORTEST_LENGTH = "shortest-length"
LEAST_ERROR = "least-error"
POLICIES = (FEWEST_HOPS, SHORTEST_LENGTH, LEAST_ERROR)

#: Path nodes kept per pair in the parallel pass; longer paths take a second pass.
_WIDTH = 8


@dataclass(frozen=True)
class Graph:
    """An undirected graph in CSR form: neighbours of node v are indices[indptr[v]:indptr[v+1]]."""

    indptr: IntArray  # (N + 1,)
    indices: IntArray  # (2E,), sorted within each row
    weights: FloatArray  # (2E,), tracking distance of each edge, cm
    labels: IntArray  # (2E,), caller's label of each edge (e.g. its pair index)
    costs: FloatArray | None = None  # (2E,), expected error of each edge (least-error)

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
        """Connected-component label of every node: (N,)."""
        from scipy.sparse import csr_matrix  # here, not at import: an FLS alone never calls it
        from scipy.sparse.csgraph import connected_components

        matrix = csr_matrix(
            (np.ones(len(self.indices)), self.indices, self.indptr), shape=(self.size,) * 2
        )
        _, labels = connected_components(matrix, directed=False)
        return np.asarray(labels, dtype=np.int64)


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


def make_graph(
    size: int,
    first: ArrayLike,
    second: ArrayLike,
    weights: ArrayLike,
    labels: ArrayLike | None = None,
    costs: ArrayLike | None = None,
) -> Graph:
    """Undirected graph on ``size`` nodes from edge lists (E,) with lengths (E,), cm.

    ``labels`` (E,) tag each edge (default: its position in the lists);
    ``costs`` (E,) are the edges' expected errors, for the least-error policy.
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    weights = np.asarray(weights, dtype=np.float64)
    labels = np.arange(len(first)) if labels is None else np.asarray(labels, dtype=np.int64)
    if not first.shape == second.shape == weights.shape == labels.shape:
        raise ValueError("`first`, `second`, `weights` and `labels` must have one length")
    if np.any(first == second):
        raise ValueError("a graph edge cannot join a node to itself")
    keys = np.minimum(first, second) * size + np.maximum(first, second)
    if np.all(first < second) and np.all(keys[1:] > keys[:-1]):
        # Edges listed as neighbour pairs are: (first, second) sorted, first < second.
        indptr, indices, edge = _symmetric_rows(size, first, second)
    else:
        tail = np.concatenate([first, second])
        head = np.concatenate([second, first])
        order = np.lexsort((head, tail))
        indptr = csr.offsets(np.bincount(tail, minlength=size))
        indices, edge = head[order], order % max(len(first), 1)
    edge_costs = None
    if costs is not None:
        costs = np.asarray(costs, dtype=np.float64)
        if costs.shape != weights.shape:
            raise ValueError("`costs` must have one value per edge")
        edge_costs = costs[edge]
    return Graph(indptr.astype(np.int64), indices, weights[edge], labels[edge], edge_costs)


@jit.kernel(cache=True, nogil=True)
def _symmetric_rows(
    size: int, first: IntArray, second: IntArray
) -> tuple[IntArray, IntArray, IntArray]:
    """CSR rows (sorted) of the undirected edges first[e] < second[e], given sorted by
    (first, second): indptr, indices, and the edge e of each entry."""
    indptr = np.zeros(size + 1, dtype=np.int64)
    for e in range(len(first)):
        indptr[first[e] + 1] += 1
        indptr[second[e] + 1] += 1
    for node in range(size):
        indptr[node + 1] += indptr[node]
    cursor = indptr[:-1].copy()
    indices = np.empty(2 * len(first), dtype=np.int64)
    edge = np.empty(2 * len(first), dtype=np.int64)
    # Row v holds its smaller neighbours (edges where v is second, in order of first),
    # then its larger ones (where v is first, already in order of second).
    for e in range(len(first)):
        slot = cursor[second[e]]
        indices[slot], edge[slot] = first[e], e
        cursor[second[e]] += 1
    for e in range(len(first)):
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


@jit.kernel(cache=True, nogil=True)
def _heap_push(
    key1: FloatArray,
    key2: FloatArray,
    item: IntArray,
    size: int,
    k1: float,
    k2: float,
    node: int,
) -> int:
    position = size
    while position > 0:
        parent = (position - 1) >> 1
        if key1[parent] < k1 or (key1[parent] == k1 and key2[parent] <= k2):
            break
        key1[position], key2[position], item[position] = key1[parent], key2[parent], item[parent]
        position = parent
    key1[position], key2[position], item[position] = k1, k2, node
    return size + 1


@jit.kernel(cache=True, nogil=True)
def _heap_pop(key1: FloatArray, key2: FloatArray, item: IntArray, size: int) -> int:
    size -= 1
    k1, k2, node = key1[size], key2[size], item[size]
    position = 0
    while True:
        child = 2 * position + 1
        if child >= size:
            break
        if child + 1 < size and (
            key1[child + 1] < key1[child]
            or (key1[child + 1] == key1[child] and key2[child + 1] < key2[child])
        ):
            child += 1
        if key1[child] > k1 or (key1[child] == k1 and key2[child] >= k2):
            break
        key1[position], key2[position], item[position] = key1[child], key2[child], item[child]
        position = child
    key1[position], key2[position], item[position] = k1, k2, node
    return size


@jit.kernel(cache=True, nogil=True)
def _walk_back(pred: IntArray, target: int, steps: int, out: IntArray) -> None:
    """Write the path ending at ``target`` (``steps`` hops) into out[0 : steps + 1]."""
    node = target
    for back in range(steps, -1, -1):
        out[back] = node
        node = pred[node]


class Search(NamedTuple):
    """A graph and a policy's weights as the search kernels take them: one argument.

    A named tuple, so that numba passes it whole (as :class:`~.sight.Grid`).
    """

    indptr: IntArray  # (N + 1,)
    indices: IntArray  # (2E,)
    weights: FloatArray  # (2E,), the weights the policy sums
    component: IntArray  # (N,), connected-component label of each node
    fewest_hops: bool  # hops are the primary cost, weights the secondary
    bucket_width: float  # width of a bucket of Dinitz's search (see _buckets)
    slots: int  # buckets kept in turn; 0 for a heap search


class Labels(NamedTuple):
    """The labels of one search over N nodes, reused search after search (see :func:`_reset`)."""

    primary: FloatArray  # (N,), primary cost; inf where unreached
    secondary: FloatArray  # (N,), secondary cost; inf where unreached
    pred: IntArray  # (N,), predecessor; -1 where unreached
    settled: NDArray[np.bool_]  # (N,)
    wanted: NDArray[np.bool_]  # (N,), the search's targets
    touched: IntArray  # (N,), the nodes labelled, in order
    order: IntArray  # (N,), the nodes settled, in order (bucket search)


class PairResults(NamedTuple):
    """The result of each of M pairs, written by :func:`_search_kernel`."""

    found: NDArray[np.bool_]  # (M,)
    hops: IntArray  # (M,)
    length: FloatArray  # (M,), cm
    buffer: IntArray  # (M, W), a found path's first nodes, up to W


@jit.kernel(cache=True, nogil=True)
def _scratch(size: int) -> Labels:
    """Unset labels of a search over ``size`` nodes."""
    return Labels(
        np.full(size, np.inf),
        np.full(size, np.inf),
        np.full(size, -1, dtype=np.int64),
        np.zeros(size, dtype=np.bool_),
        np.zeros(size, dtype=np.bool_),
        np.empty(size, dtype=np.int64),
        np.empty(size, dtype=np.int64),
    )


@jit.kernel(cache=True, nogil=True)
def _reset(labels: Labels, count: int) -> None:
    """Unset the labels of the first ``count`` touched nodes after a search, for the next one."""
    primary, secondary, pred, settled, _, touched, _ = labels
    for node in touched[:count]:
        primary[node], secondary[node], pred[node] = np.inf, np.inf, -1
        settled[node] = False


@jit.kernel(cache=True, nogil=True)
def _search_one(search: Search, source: int, targets: IntArray, labels: Labels) -> int:
    """Search from ``source`` until every reachable target is settled; return nodes touched.

    With ``search.slots`` > 0, Dinitz's buckets (see :func:`_buckets`); else a
    heap. Leaves cost labels in ``labels.primary``/``secondary`` and
    predecessors in ``labels.pred`` for the touched nodes; the caller resets them.
    """
    if search.slots > 0:
        return _search_buckets(search, source, targets, labels)
    return _search_heap(search, source, targets, labels)


@jit.kernel(cache=True, nogil=True)
def _mark_targets(
    source: int, targets: IntArray, component: IntArray, wanted: NDArray[np.bool_]
) -> int:
    """Mark the targets in the source's component as wanted; return how many were marked."""
    remaining = 0
    for target in targets:
        if component[target] == component[source] and not wanted[target]:
            wanted[target] = True
            remaining += 1
    return remaining


@jit.kernel(cache=True, nogil=True)
def _start(source: int, labels: Labels) -> None:
    """Label ``source`` as reached at cost (0, 0), the first node touched."""
    labels.primary[source] = 0.0
    labels.secondary[source] = 0.0
    labels.pred[source] = source
    labels.touched[0] = source


@jit.kernel(cache=True, nogil=True)
def _settle_bucket(
    labels: Labels, entry: int, entry_node: IntArray, entry_next: IntArray, done: int
) -> tuple[int, int, int]:
    """Settle the nodes of the bucket list from ``entry``, appending them to ``labels.order``
    at ``done``; return the new ``done``, the entries listed and the wanted nodes settled."""
    listed = reached = 0
    while entry >= 0:
        listed += 1
        node = entry_node[entry]
        entry = entry_next[entry]
        # A node listed twice (its label improved within the bucket) settles once.
        if not labels.settled[node]:
            labels.settled[node] = True
            labels.order[done] = node
            done += 1
            if labels.wanted[node]:
                reached += 1
    return done, listed, reached


@jit.kernel(cache=True, nogil=True)
def _doubled(array: IntArray, used: int) -> IntArray:
    """A copy of ``array`` twice as long, of which the first ``used`` entries are set."""
    grown = np.empty(2 * len(array), dtype=np.int64)
    grown[:used] = array[:used]
    return grown


@jit.kernel(cache=True, nogil=True)
def _search_buckets(search: Search, source: int, targets: IntArray, labels: Labels) -> int:
    """Dinitz's algorithm: settle a whole bucket of labels at once, then relax its edges.

    Bucket k holds the labels in [k * bucket_width, (k + 1) * bucket_width), and the width is
    at most the smallest edge: no label of bucket k can be improved through
    a node of bucket k or later, so all of bucket k is final once the
    buckets before it have relaxed their edges. Every node through which a
    label is reached at its cost lies in an earlier bucket, so the
    predecessor rule sees them all. The search stops as soon as the last
    target's bucket is reached, without relaxing it.
    """
    indptr, indices, weights, component, fewest_hops, bucket_width, slots = search
    primary, secondary, pred, settled, wanted, touched, order = labels
    remaining = _mark_targets(source, targets, component, wanted)
    entry_node = np.empty(1024, dtype=np.int64)
    entry_next = np.empty(1024, dtype=np.int64)
    head = np.full(slots, -1, dtype=np.int64)
    _start(source, labels)
    count = 1
    entry_node[0], entry_next[0], head[0] = source, -1, 0
    used, pending, bucket, done = 1, 1, 0, 0
    while pending > 0 and remaining > 0:
        slot = bucket % slots
        first = done
        done, listed, reached = _settle_bucket(labels, head[slot], entry_node, entry_next, done)
        head[slot] = -1
        pending -= listed
        remaining -= reached
        bucket += 1
        if remaining == 0:
            break
        for position in range(first, done):
            node = order[position]
            k1, k2 = primary[node], secondary[node]
            for edge in range(indptr[node], indptr[node + 1]):
                neighbour = indices[edge]
                n1 = k1 + 1.0 if fewest_hops else k1 + weights[edge]
                p1 = primary[neighbour]
                # Most edges of a dense graph lead nowhere better: decide on the first key.
                if n1 > p1 or settled[neighbour]:
                    continue
                n2 = k2 + weights[edge] if fewest_hops else k2 + 1.0
                p2 = secondary[neighbour]
                if p1 == np.inf:
                    touched[count] = neighbour
                    count += 1
                if n1 < p1 or n2 < p2:
                    primary[neighbour] = n1
                    secondary[neighbour] = n2
                    pred[neighbour] = node
                    # The next bucket at least: a label never returns to a bucket relaxed.
                    target_bucket = max(int(n1 / bucket_width), bucket)
                    if p1 < np.inf and target_bucket == max(int(p1 / bucket_width), bucket):
                        continue  # listed in that bucket already
                    if used == len(entry_node):
                        entry_node = _doubled(entry_node, used)
                        entry_next = _doubled(entry_next, used)
                    target_slot = target_bucket % slots
                    entry_node[used], entry_next[used] = neighbour, head[target_slot]
                    head[target_slot] = used
                    used += 1
                    pending += 1
                elif n2 == p2 and node < pred[neighbour]:
                    pred[neighbour] = node
    return count


@jit.kernel(cache=True, nogil=True)
def _search_heap(search: Search, source: int, targets: IntArray, labels: Labels) -> int:
    """Dijkstra with a binary heap, for edges too unequal for buckets; see :func:`_search_one`."""
    indptr, indices, weights, component, fewest_hops, _, _ = search
    primary, secondary, pred, settled, wanted, touched, _ = labels
    remaining = _mark_targets(source, targets, component, wanted)
    capacity = 64
    heap1 = np.empty(capacity)
    heap2 = np.empty(capacity)
    heap_item = np.empty(capacity, dtype=np.int64)
    _start(source, labels)
    count = 1
    size = _heap_push(heap1, heap2, heap_item, 0, 0.0, 0.0, source)
    while size > 0 and remaining > 0:
        k1, k2, node = heap1[0], heap2[0], heap_item[0]
        size = _heap_pop(heap1, heap2, heap_item, size)
        if settled[node] or k1 != primary[node] or k2 != secondary[node]:
            continue
        settled[node] = True
        if wanted[node]:
            remaining -= 1
        for slot in range(indptr[node], indptr[node + 1]):
            neighbour = indices[slot]
            if settled[neighbour]:
                continue
            if fewest_hops:
                n1, n2 = k1 + 1.0, k2 + weights[slot]
            else:
                n1, n2 = k1 + weights[slot], k2 + 1.0
            p1, p2 = primary[neighbour], secondary[neighbour]
            if p1 == np.inf:
                touched[count] = neighbour
                count += 1
            if n1 < p1 or (n1 == p1 and n2 < p2):
                primary[neighbour] = n1
                secondary[neighbour] = n2
                pred[neighbour] = node
                if size == capacity:
                    capacity *= 2
                    grown1 = np.empty(capacity)
                    grown2 = np.empty(capacity)
                    grown_item = np.empty(capacity, dtype=np.int64)
                    grown1[:size], grown2[:size], grown_item[:size] = (
                        heap1[:size],
                        heap2[:size],
                        heap_item[:size],
                    )
                    heap1, heap2, heap_item = grown1, grown2, grown_item
                size = _heap_push(heap1, heap2, heap_item, size, n1, n2, neighbour)
            elif n1 == p1 and n2 == p2 and node < pred[neighbour]:
                pred[neighbour] = node
    return count


@jit.kernel(cache=True, parallel=True)
def _search_kernel(
    search: Search,
    sources: IntArray,
    target_ptr: IntArray,
    targets: IntArray,
    chunks: int,
    results: PairResults,
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
        labels = _scratch(size)
        primary, secondary, pred, settled, wanted, _, _ = labels
        for position in range(chunk, len(sources), chunks):
            source = sources[position]
            mine = targets[target_ptr[position] : target_ptr[position + 1]]
            count = _search_one(search, source, mine, labels)
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
                    _walk_back(pred, target, steps, buffer[pair])
            _reset(labels, count)
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
    labels = _scratch(len(search.indptr) - 1)
    for position in range(len(sources)):
        start, stop = target_ptr[position], target_ptr[position + 1]
        if np.all(hops[start:stop] + 1 <= width):
            continue
        count = _search_one(search, sources[position], targets[start:stop], labels)
        for pair in range(start, stop):
            if hops[pair] + 1 > width:
                _walk_back(labels.pred, targets[pair], hops[pair], nodes[offsets[pair] :])
        _reset(labels, count)
        labels.wanted[targets[start:stop]] = False


def check_policy(policy: str) -> str:
    """Return ``policy`` if it names a path policy, else raise ValueError listing them."""
    if policy not in POLICIES:
        raise ValueError(f"unknown path policy {policy!r}; expected one of {', '.join(POLICIES)}")
    return policy


def _policy_weights(graph: Graph, policy: str) -> tuple[FloatArray, bool]:
    """The edge weights a search sums under ``policy`` (2E,), and whether hops come first."""
    # Least-error is shortest-length over the edges' costs instead of their lengths.
    if check_policy(policy) == LEAST_ERROR:
        if graph.costs is None:
            raise ValueError("the least-error policy needs a graph with edge costs")
        return graph.costs, False
    return graph.weights, policy == FEWEST_HOPS


#: Most buckets a search keeps in turn; edges more unequal than this are searched with a heap.
_MOST_BUCKETS = 4096


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


@jit.kernel(cache=True, parallel=True)
def _avoiding_kernel(
    search: Search,
    sources: IntArray,
    targets: IntArray,
    avoid_offsets: IntArray,
    avoid: IntArray,
    width: int,
    chunks: int,
) -> tuple[NDArray[np.bool_], IntArray, IntArray]:
    fewest_hops = search.fewest_hops
    size = len(search.indptr) - 1
    pairs = len(targets)
    found = np.zeros(pairs, dtype=np.bool_)
    hops = np.zeros(pairs, dtype=np.int64)
    buffer = np.full((pairs, width), -1, dtype=np.int64)
    for chunk in jit.prange(chunks):
        labels = _scratch(size)
        primary, secondary, pred, settled, wanted, _, _ = labels
        one = np.empty(1, dtype=np.int64)
        for pair in range(chunk, pairs, chunks):
            source, target = sources[pair], targets[pair]
            # An avoided node counts as settled: the search never enters it.
            blocked = avoid[avoid_offsets[pair] : avoid_offsets[pair + 1]]
            settled[blocked] = True
            one[0] = target
            count = _search_one(search, source, one, labels)
            if target != source and primary[target] < np.inf and settled[target]:
                steps = int(primary[target] if fewest_hops else secondary[target])
                if steps + 1 <= width:
                    found[pair] = True
                    hops[pair] = steps
                    _walk_back(pred, target, steps, buffer[pair])
            _reset(labels, count)
            settled[blocked] = False
            wanted[target] = False
    return found, hops, buffer


#: Longest path, in nodes, that :func:`avoiding_paths` returns.
AVOIDING_WIDTH = 64


def _search_of(graph: Graph, policy: str, components: IntArray | None) -> Search:
    """The record the search kernels take for ``policy`` on ``graph``."""
    weights, fewest_hops = _policy_weights(graph, policy)
    if components is None:
        components = graph.components()
    return Search(
        graph.indptr,
        graph.indices,
        weights,
        components,
        fewest_hops,
        *_buckets(weights, fewest_hops),
    )


def avoiding_paths(
    graph: Graph,
    sources: ArrayLike,
    targets: ArrayLike,
    policy: str,
    avoid_offsets: ArrayLike,
    avoid: ArrayLike,
    components: IntArray | None = None,
) -> Paths:
    """The policy's path for each pair (sources[m], targets[m]) that enters none of its nodes
    avoid[avoid_offsets[m]:avoid_offsets[m + 1]].

    Pairs in any order; one search per pair. A path longer than
    AVOIDING_WIDTH nodes counts as not found. Lengths are tracking distances.
    """
    search = _search_of(graph, policy, components)
    sources = np.asarray(sources, dtype=np.int64)
    targets = np.asarray(targets, dtype=np.int64)
    found, hops, buffer = _avoiding_kernel(
        search,
        sources,
        targets,
        np.asarray(avoid_offsets, dtype=np.int64),
        np.asarray(avoid, dtype=np.int64),
        AVOIDING_WIDTH,
        max(1, min(len(sources), 4 * jit.get_num_threads())),
    )
    counts = np.where(found, hops + 1, 0)
    offsets = csr.offsets(counts)
    nodes = np.empty(offsets[-1], dtype=np.int64)
    _compress(buffer, counts, offsets, nodes)
    paths = Paths(found, hops, np.full(len(found), np.nan), offsets, nodes)
    return replace(paths, length=path_sums(graph, paths, graph.weights))


def shortest_paths(
    graph: Graph,
    sources: ArrayLike,
    targets: ArrayLike,
    policy: str,
    components: IntArray | None = None,
    progress: Callable[[int], None] | None = None,
    batch: int = 512,
) -> Paths:
    """The policy's path for each pair (sources[m], targets[m]); pairs sorted by source.

    Parameters
    ----------
    graph : Graph
    sources, targets : (M,) array_like of int
        Pairs, grouped by source (all pairs of one source adjacent).
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        least-error needs ``graph.costs``; its paths' ``length`` is still the
        sum of their tracking distances.
    components : (N,) array of int, optional
        ``graph.components()``, when the caller has it already.
    progress : callable, optional
        Called with the number of pairs done after each batch of sources.
    """
    sources = np.asarray(sources, dtype=np.int64)
    targets = np.asarray(targets, dtype=np.int64)
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
    if sources.shape != targets.shape:
        raise ValueError("`sources` and `targets` must have one length")
    if len(sources) and (sources.min() < 0 or max(sources.max(), targets.max()) >= graph.size):
        raise ValueError("`sources` and `targets` must be nodes of the graph")
    if len(sources) > 1 and np.any(sources[1:] < sources[:-1]):
        raise ValueError("pairs must be sorted by source")


def _search_batches(
    search: Search,
    sources: IntArray,
    targets: IntArray,
    progress: Callable[[int], None] | None,
    batch: int,
) -> PairResults:
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
            PairResults(found[lo:hi], hops[lo:hi], length[lo:hi], buffer[lo:hi]),
        )
        if progress is not None:
            progress(int(hi - lo))
    return PairResults(found, hops, length, buffer)


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


def paths_from_rows(
    size: int, rows: dict[int, list[int]], lengths: dict[int, float] | None = None
) -> Paths:
    """Paths of ``size`` pairs from {pair: nodes}; pairs without a row have none.

    ``lengths`` gives {pair: length, cm}; lengths are NaN where not given.
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
    """Sum of ``values`` (2E,), one per edge of ``graph``, along each path: (M,); NaN if none.

    Summed from the source outwards, as a search and the distributed
    protocol sum them, so that equal paths give equal floats.
    """
    pair, start, end = path_hops(paths)
    # bincount adds in array order, and path_hops lists each path's hops in order.
    sums = np.bincount(
        pair, weights=values[graph.edge_positions(start, end)], minlength=len(paths.found)
    )
    return np.where(paths.found, sums, np.nan)


def path_hops(paths: Paths) -> tuple[IntArray, IntArray, IntArray]:
    """Every hop of every path: (pair, from, to), each (H,), in path order."""
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


@jit.kernel(cache=True, parallel=True)
def _compress(buffer: IntArray, counts: IntArray, offsets: IntArray, nodes: IntArray) -> None:
    """Copy the first counts[m] nodes of row m of ``buffer`` (M, W) to nodes[offsets[m]:]."""
    for row in jit.prange(len(counts)):
        for column in range(min(counts[row], buffer.shape[1])):
            nodes[offsets[row] + column] = buffer[row, column]
