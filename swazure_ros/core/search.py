"""One search from one source: the labels, the heap and Dinitz's buckets (numba kernels).

The workhorse under :mod:`.paths`, whose functions run it from many sources
at once. A search settles nodes in order of their (primary, secondary) cost
(hops then length for fewest-hops; length or error then hops otherwise) and
keeps, for each node, the predecessor of the smallest FLS index among those
that reach it at its cost (the tie-break of :mod:`.paths`). :func:`search_from`
leaves its labels in a :class:`Labels`, which :func:`walk_back` reads a
path from and :func:`reset_labels` unsets for the next search.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from . import jit
from .arrays import FloatArray, IntArray


class Search(NamedTuple):
    """A graph and a policy's weights as the search kernels take them: one argument.

    A named tuple, so that numba passes it whole (as :class:`~.grid.Grid`).
    """

    indptr: IntArray  # (N + 1,)
    indices: IntArray  # (2E,)
    weights: FloatArray  # (2E,), the weights the policy sums
    component: IntArray  # (N,), connected-component label of each node
    fewest_hops: bool  # hops are the primary cost, weights the secondary
    bucket_width: float  # width of a bucket of Dinitz's search (see paths._buckets)
    slots: int  # buckets kept in turn; 0 for a heap search
    bands: IntArray  # (N, B + 1), where each band a search reads begins (B = 1: the rows)
    floors: FloatArray  # (B,), the least weight of each band; 0 where it is not to be skipped
    positions: FloatArray  # (N, 3), each node's place, cm; (0, 3) where unknown
    reach: float  # the least primary cost a path has per cm of its ends' distance; 0: unknown


class Labels(NamedTuple):
    """The labels of one search over N nodes, reused search after search (:func:`reset_labels`)."""

    primary: FloatArray  # (N,), primary cost; inf where unreached
    secondary: FloatArray  # (N,), secondary cost; inf where unreached
    pred: IntArray  # (N,), predecessor; -1 where unreached
    settled: NDArray[np.bool_]  # (N,)
    wanted: NDArray[np.bool_]  # (N,), the search's targets
    touched: IntArray  # (N,), the nodes labelled, in order
    order: IntArray  # (N,), the nodes settled, in order (bucket search)
    near: FloatArray  # (N,), a lone target's neighbours' edges to it; inf elsewhere


@jit.kernel(cache=True, nogil=True)
def fresh_labels(size: int) -> Labels:
    """Unset labels of a search over ``size`` nodes, for search after search.

    Parameters
    ----------
    size : int
        N, the graph's nodes.

    Returns
    -------
    Labels
        Costs infinite, no predecessor (-1), nothing settled or wanted.
    """
    return Labels(
        np.full(size, np.inf),
        np.full(size, np.inf),
        np.full(size, -1, dtype=np.int64),
        np.zeros(size, dtype=np.bool_),
        np.zeros(size, dtype=np.bool_),
        np.empty(size, dtype=np.int64),
        np.empty(size, dtype=np.int64),
        np.full(size, np.inf),
    )


@jit.kernel(cache=True, nogil=True)
def reset_labels(labels: Labels, count: int) -> None:
    """Unset what a search labelled, for the next search: a cost in proportion to what it touched.

    Parameters
    ----------
    labels : Labels
        As :func:`search_from` left them.
    count : int
        The nodes it touched, as it returned.
    """
    primary, secondary, pred, settled, _, touched, _, _ = labels
    for node in touched[:count]:
        primary[node], secondary[node], pred[node] = np.inf, np.inf, -1
        settled[node] = False


@jit.kernel(cache=True, nogil=True)
def search_from(search: Search, source: int, targets: IntArray, labels: Labels) -> int:
    """Search from ``source`` until every target it can reach is settled.

    With ``search.slots`` > 0, Dinitz's buckets (:func:`_search_buckets`);
    else a binary heap (:func:`_search_heap`). Both give the targets, and every
    node of the paths to them, the same labels and predecessors; the buckets
    leave out offers dearer than every target still wanted, so a node off
    those paths may keep a dearer label than the heap gives it, or none.

    Parameters
    ----------
    search : Search
        The graph and the policy's weights.
    source : int
        The node the search starts from.
    targets : (K,) ndarray of int
        The nodes wanted; the search ends once the last of those in the
        source's component is settled.
    labels : Labels
        Unset (:func:`fresh_labels`, :func:`reset_labels`); gets each touched
        node's costs in ``primary`` and ``secondary``, its predecessor in
        ``pred``, and ``settled``. The caller unsets ``wanted[targets]``.

    Returns
    -------
    int
        The nodes touched: the first entries of ``labels.touched``, to reset.
    """
    if search.slots > 0:
        return _search_buckets(search, source, targets, labels)
    return _search_heap(search, source, targets, labels)


@jit.kernel(cache=True, nogil=True)
def walk_back(pred: IntArray, target: int, steps: int, out: IntArray) -> None:
    """Write the path of ``steps`` hops that a search found to ``target`` into ``out``.

    Parameters
    ----------
    pred : (N,) ndarray of int
        The search's predecessors (``Labels.pred``).
    target : int
        The path's last node, settled by the search.
    steps : int
        The path's hops.
    out : (steps + 1,) or longer ndarray of int
        Gets the path's nodes, source first, in ``out[0 : steps + 1]``.
    """
    node = target
    for back in range(steps, -1, -1):
        out[back] = node
        node = pred[node]


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
def _target_bound(
    targets: IntArray, primary: FloatArray, settled: NDArray[np.bool_], wanted: NDArray[np.bool_]
) -> float:
    """The largest first cost of the targets still wanted: inf while one has none.

    Labels only fall, so each such target's final cost is at most this, and an
    offer above it can improve no target, nor any node of a target's path.
    """
    bound = 0.0
    for target in targets:
        if wanted[target] and not settled[target] and primary[target] > bound:
            bound = primary[target]
    return bound


@jit.kernel(cache=True, nogil=True)
def _targets_ball(
    positions: FloatArray, source: int, targets: IntArray
) -> tuple[float, float, float, float]:
    """A ball that holds every target, cm: its centre (x, y, z) and radius.

    One target is its own centre; several lie within the farthest's distance
    of the source.
    """
    if len(targets) == 1:
        place = positions[targets[0]]
        return place[0], place[1], place[2], 0.0
    place = positions[source]
    radius = 0.0
    for target in targets:
        radius = max(radius, _distance(positions[target], place[0], place[1], place[2]))
    return place[0], place[1], place[2], radius


@jit.kernel(cache=True, nogil=True)
def _distance(place: FloatArray, x: float, y: float, z: float) -> float:
    """Distance from ``place`` (3,) to (x, y, z), cm."""
    dx, dy, dz = place[0] - x, place[1] - y, place[2] - z
    return float(np.sqrt(dx * dx + dy * dy + dz * dz))


@jit.kernel(cache=True, nogil=True)
def _beyond(positions: FloatArray, node: int, ball: tuple[float, float, float, float]) -> float:
    """How far ``node`` lies outside ``ball`` (:func:`_targets_ball`), cm: 0 within it."""
    x, y, z, radius = ball
    return max(0.0, _distance(positions[node], x, y, z) - radius)


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

    A row laid out in bands of weight (``search.bands``) is read band by band,
    and a band whose least weight the node cannot afford within the bound is
    skipped whole: the offers left out are those the bound leaves out one by
    one. The order in which a node's offers come changes no label and no tie
    (the least costs win, and at equal costs the smallest predecessor).

    With places (``search.reach`` > 0), a node is left out, unlabelled or
    unrelaxed, when its cost plus ``reach`` times its distance to the
    targets' ball exceeds the bound: no path to a target within the bound
    runs through it. Every node through which a target is reached at its
    cost lies on such a path, so no target's label, nor any tie, changes.
    A search for one target takes as its bound, as soon as a neighbour of
    the target has a label, that label plus their edge (``labels.near``,
    set for the search): the cost of a path to the target, which the
    neighbour will offer it a bucket later.
    """
    indices, weights, _, fewest_hops = search[1:5]
    bucket_width, slots, bands, floors, positions, reach = search[5:]
    primary, secondary, pred, settled, wanted, touched, order, near = labels
    remaining, unlabelled, lone, ball = _begin(search, source, targets, labels)
    entry_node, entry_next = np.empty(1024, dtype=np.int64), np.empty(1024, dtype=np.int64)
    head = np.full(slots, -1, dtype=np.int64)
    entry_node[0], entry_next[0], head[0] = source, -1, 0
    # The bound's parts: the dearest wanted target's label and a lone target's bound.
    upper = dearest = np.inf
    count, used, pending, bucket, done = 1, 1, 1, 0, 0
    while pending > 0 and remaining > 0:
        first, slot = done, bucket % slots
        done, listed, reached = _settle_bucket(labels, head[slot], entry_node, entry_next, done)
        head[slot] = -1
        pending, remaining = pending - listed, remaining - reached
        bucket += 1
        if remaining == 0:
            break
        # No label above the dearest wanted target's can lead to a target or lie on its path:
        # such offers are left out before their node is looked up (docs/core.md).
        dearest = _target_bound(targets, primary, settled, wanted)
        bound = min(dearest, upper)
        # Labels and distances round far below 1e-9 of the bound (Graph.reach_ratio).
        far, limit = reach > 0.0 and bound < np.inf, bound * (1.0 + 1e-9)
        for position in range(first, done):
            node = order[position]
            k1, k2 = primary[node], secondary[node]
            if fewest_hops and k1 + 1.0 > bound:
                continue
            if far and k1 + reach * _beyond(positions, node, ball) > limit:
                continue
            for band in range(len(floors)):
                # A band whose least weight is beyond the bound has no offer to hear.
                if k1 + floors[band] > bound:
                    continue
                for edge in range(bands[node, band], bands[node, band + 1]):
                    n1 = k1 + 1.0 if fewest_hops else k1 + weights[edge]
                    if n1 > bound:
                        continue
                    neighbour = indices[edge]
                    p1 = primary[neighbour]
                    # Most edges of a dense graph lead nowhere better: decide on the first key.
                    if n1 > p1 or settled[neighbour]:
                        continue
                    n2 = k2 + weights[edge] if fewest_hops else k2 + 1.0
                    p2 = secondary[neighbour]
                    if p1 == np.inf:
                        if far and n1 + reach * _beyond(positions, neighbour, ball) > limit:
                            continue
                        touched[count] = neighbour
                        count += 1
                    if n1 < p1 or n2 < p2:
                        primary[neighbour], secondary[neighbour], pred[neighbour] = n1, n2, node
                        # Inline: a call at every fallen label costs the searches 2-3x.
                        if wanted[neighbour] and n1 < p1:
                            unlabelled -= 1 if p1 == np.inf else 0
                            # Only when the dearest falls: a sweet search's hundreds often do.
                            if unlabelled == 0 and p1 >= dearest:
                                dearest = _target_bound(targets, primary, settled, wanted)
                        # A path to the lone target through this neighbour bounds its cost.
                        upper = min(upper, n1 + near[neighbour])
                        bound = min(dearest, upper)
                        far, limit = reach > 0.0 and bound < np.inf, bound * (1.0 + 1e-9)
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
    _mark_near(search, lone, near, False)
    return count


@jit.kernel(cache=True, nogil=True)
def _begin(
    search: Search, source: int, targets: IntArray, labels: Labels
) -> tuple[int, int, int, tuple[float, float, float, float]]:
    """A bucket search's start: the source labelled, the targets marked (a lone target's
    neighbours' edges too, :func:`_mark_near`), and the ball that holds them.

    Returns the targets marked, those of them without a label yet, the lone
    target (-1 unless one) and the ball (:func:`_targets_ball`; zeros without places).
    """
    remaining = _mark_targets(source, targets, search.component, labels.wanted)
    _start(source, labels)
    unlabelled = remaining - (1 if labels.wanted[source] else 0)
    lone = targets[0] if len(targets) == 1 and remaining == 1 else -1
    _mark_near(search, lone, labels.near, True)
    if search.reach > 0.0:
        return remaining, unlabelled, lone, _targets_ball(search.positions, source, targets)
    return remaining, unlabelled, lone, (0.0, 0.0, 0.0, 0.0)


@jit.kernel(cache=True, nogil=True)
def _mark_near(search: Search, target: int, near: FloatArray, marked: bool) -> None:
    """Set ``near`` of each neighbour of ``target`` to the cost of its edge to the target
    (fewest-hops: 1), or, not ``marked``, back to inf; no target (-1), none."""
    if target < 0:
        return
    for entry in range(search.indptr[target], search.indptr[target + 1]):
        cost = 1.0 if search.fewest_hops else search.weights[entry]
        near[search.indices[entry]] = cost if marked else np.inf


@jit.kernel(cache=True, nogil=True)
def _search_heap(search: Search, source: int, targets: IntArray, labels: Labels) -> int:
    """Dijkstra with a binary heap, for edges too unequal for buckets; see :func:`search_from`."""
    indptr, indices, weights, component, fewest_hops = search[:5]
    primary, secondary, pred, settled, wanted, touched, _, _ = labels
    remaining = _mark_targets(source, targets, component, wanted)
    heap1, heap2, heap_item = np.empty(64), np.empty(64), np.empty(64, dtype=np.int64)
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
                heap1, heap2, heap_item = _heap_room(heap1, heap2, heap_item, size)
                size = _heap_push(heap1, heap2, heap_item, size, n1, n2, neighbour)
            elif n1 == p1 and n2 == p2 and node < pred[neighbour]:
                pred[neighbour] = node
    return count


@jit.kernel(cache=True, nogil=True)
def _heap_room(
    key1: FloatArray, key2: FloatArray, item: IntArray, size: int
) -> tuple[FloatArray, FloatArray, IntArray]:
    """The heap's arrays, twice as long when ``size`` entries fill them: room for one more."""
    if size < len(item):
        return key1, key2, item
    grown1, grown2 = np.empty(2 * size), np.empty(2 * size)
    grown_item = np.empty(2 * size, dtype=np.int64)
    grown1[:size], grown2[:size], grown_item[:size] = key1[:size], key2[:size], item[:size]
    return grown1, grown2, grown_item


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
