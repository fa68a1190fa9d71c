"""Move Obstructing (spec, section 7): the FLSs that block a hop step aside.

Two behaviours, chosen by :class:`~.compat.Compat`: :func:`obstructing_text`
moves a pair's obstructers in sequence, each collision check seeing the
earlier moves, and checks every hop after them; :func:`obstructing_published`
finds each obstructer's destination in the original shape, as the published
code does. :func:`move_obstructing` runs the one the switches ask for.

Conventions beyond the spec:

- An FLS steps aside onto the obstruction-free circle enlarged by a relative
  1e-9 (``_ASIDE``): plain line of sight counts a centre at exactly r as
  obstructing, and a swarm that makes the move for real (the coordinator's
  Move Obstructing) must then see the hop clear when it measures again.
- Obstructers of a hop are taken in the current configuration when the hop is
  processed, in path order and by increasing FLS index; so an FLS moved into
  a later hop moves again, and one moved into an earlier hop fails the pair at
  the final check.
- An FLS of the path itself cannot step aside: if it obstructs a hop, Move
  Obstructing fails for the pair.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .. import csr, jit
from ..hops import estimates
from ..path_arrays import Paths, path_hops, paths_from_rows
from ..paths import shortest_paths
from ..sight import obstructers

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

from ...core.arrays import FloatArray, IntArray
from ..circles import circle_sphere_crossings, fixed_axis, free_circle_kernel
from ..grid import Grid, scan_ball
from ..segments import closest_on_segment, near_any_segment, segment_gap
from .compat import TEXT, Compat
from .result import MOVE_OBSTRUCTING, HeuristicResult, PairFindings, PlainPairs, blocked_pairs

#: Slack when deciding that an FLS on the obstruction-free circle clears a line of sight, cm.
TOUCH = 1e-9


#: An FLS steps aside this fraction of r beyond the obstruction-free circle.
_ASIDE = 1e-9


def _published_destination(
    points: FloatArray,
    radius: float,
    tree: cKDTree,
    fls: int,
    start: FloatArray,
    end: FloatArray,
    compat: Compat,
) -> FloatArray | None:
    """Where obstructer ``fls`` goes to clear the hop start-end in the original shape, or None."""
    position = points[fls]
    centre = closest_on_segment(start, end, position)
    offset = position - centre
    if offset.any():
        ideal = position + (radius / np.linalg.norm(offset) - 1.0) * offset
    else:
        # A centre on the hop itself: every point of the circle is as near; the text's
        # fixed one (circles.free_circle_point), where the reference divides by zero.
        hop = end - start
        ideal = centre + radius * fixed_axis(hop / np.linalg.norm(hop))
    # The reference looks for a collision of the ideal move among the FLSs whose
    # tracking distance from `fls` is at most |fls - ideal|, with the FLS's index
    # standing for its position; reproduced so that its tables are.
    reach = float(np.linalg.norm(fls - ideal)) + 2.0 * radius
    near = [k for k in tree.query_ball_point(ideal, 2.0 * radius) if k != fls]
    collides = any(
        np.linalg.norm(points[k] - ideal) < 2.0 * radius
        and np.linalg.norm(points[k] - position) <= reach
        for k in near
    )
    if not collides:
        return np.asarray(ideal)
    # Every FLS within 4r (tracking distance 2r) can stand within 2r of the circle.
    proximity = [k for k in tree.query_ball_point(position, 4.0 * radius) if k != fls]
    proximity.sort(key=lambda k: (float(np.linalg.norm(points[k] - position)), k))
    spheres = proximity[-1:] if compat.last_neighbour_circle else proximity
    crossings = [
        circle_sphere_crossings(centre, end - start, radius, points[k], 2.0 * radius)
        for k in spheres
    ]
    candidates = np.concatenate([np.zeros((0, 3)), *crossings])
    if len(candidates) == 0:
        return None
    gaps = np.linalg.norm(candidates[:, None, :] - points[proximity][None, :, :], axis=2)
    clear = gaps >= 2.0 * radius * (1.0 - 1e-12)  # a crossing lies on its own sphere
    usable = clear.any(axis=1) if compat.clear_of_any_one else clear.all(axis=1)
    if not usable.any():
        return None
    candidates = candidates[usable]
    return np.asarray(candidates[np.argmin(np.linalg.norm(candidates - position, axis=1))])


def _blocked_hops(
    evaluation: PlainPairs,
) -> tuple[IntArray, Paths, IntArray, IntArray, IntArray, IntArray]:
    """The BLOCKED pairs, their S_all paths, and the obstructers of each hop's edge.

    Returns (blocked pairs (B,), their paths, the edge label of every hop
    (H,), the distinct labels (E,), and the obstructers in the original shape
    as a CSR over those labels: offsets (E + 1,), swarm indices).
    """
    hood, pairs = evaluation.hood, evaluation.pairs
    blocked = blocked_pairs(evaluation)
    sweet_paths = shortest_paths(
        hood.sweet_all, pairs.source[blocked], pairs.target[blocked], evaluation.policy
    )
    _, start, end = path_hops(sweet_paths)
    edge = hood.sweet_all.edge_labels(start, end)
    edges = np.unique(edge)
    offsets, ids = obstructers(
        hood.swarm.points,
        hood.swarm.radius,
        hood.pairs.first[edges],
        hood.pairs.second[edges],
        hood.grid,
    )
    return blocked, sweet_paths, edge, edges, offsets, ids


def _obstructing_result(
    evaluation: PlainPairs,
    blocked: IntArray,
    new_paths: dict[int, list[int]],
    move_counts: IntArray,
    move_fls: IntArray,
    move_from: FloatArray,
    move_to: FloatArray,
    compat: Compat,
) -> HeuristicResult:
    """Move Obstructing's outcome: the pairs ``new_paths`` resolved, the moves as a CSR."""
    size = len(evaluation.pairs)
    found = PairFindings.nothing_yet(size)
    found.tried[blocked] = True
    resolved = found.resolved
    resolved[list(new_paths)] = True
    paths = paths_from_rows(size, new_paths)
    estimate, _, _ = estimates(evaluation.hood, paths)
    found.estimate[resolved] = estimate[resolved]
    found.truth[resolved] = evaluation.pairs.truth[resolved]
    return HeuristicResult(
        technique=MOVE_OBSTRUCTING,
        threshold=None,
        tried=found.tried,
        resolved=found.resolved,
        estimate=found.estimate,
        truth=found.truth,
        paths=paths,
        move_offsets=csr.offsets(move_counts),
        move_fls=move_fls,
        move_from=move_from,
        move_to=move_to,
        compat=compat,
    )


def move_obstructing(evaluation: PlainPairs, compat: Compat = TEXT) -> HeuristicResult:
    """Move Obstructing (section 7) on every BLOCKED pair of a plain evaluation.

    As the text (:func:`obstructing_text`) unless ``compat`` moves obstructers
    independently, as published (:func:`obstructing_published`). For each
    pair, the obstructers of its policy path in ``S_all`` step onto the
    obstruction-free circle of their hop, at the free point nearest them;
    the pair is resolved when every hop of that path is then in sight.

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs.
    compat : Compat, default TEXT

    Returns
    -------
    HeuristicResult
        Per pair (M of ``evaluation.pairs``): tried, resolved, path, estimate
        and truth; every move (FLS, from, to, cm), in order.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.clouds import cube_lattice
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> jitter = np.random.default_rng(0).normal(0.0, 0.1, (64, 3))
    >>> swarm = make_swarm(cube_lattice(64) * 2.6 + jitter, radius=1.0)  # a 4x4x4 block, cm
    >>> plain = evaluate(swarm, published, "shortest-length")
    >>> from swazure_ros.core.heuristics.obstructing import move_obstructing
    >>> result = move_obstructing(plain)
    >>> int(result.resolved.sum()), len(result.move_fls)  # pairs resolved; every move made
    (500, 1882)
    >>> bool(result.move_distance.max() <= swarm.radius * 1.2)  # a step aside of about r
    True
    """
    if compat.independent_moves:
        return obstructing_published(evaluation, compat)
    return obstructing_text(evaluation)


def obstructing_text(evaluation: PlainPairs) -> HeuristicResult:
    """Move Obstructing as the text has it (spec, section 7).

    A pair's obstructers move in sequence, each collision check seeing the
    earlier moves, and every hop is checked after them. An FLS of the path
    itself cannot step aside: the pair fails.

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs.

    Returns
    -------
    HeuristicResult
        With ``compat`` :data:`~.compat.TEXT`.
    """
    points, radius = evaluation.hood.swarm.points, evaluation.hood.swarm.radius
    size = len(evaluation.pairs)
    blocked, sweet_paths, edge, edges, offsets, ids = _blocked_hops(evaluation)
    found, counts, move_fls, move_from, move_to = _text_moves_in_parts(
        points, float(radius), evaluation.hood.grid, sweet_paths, edge, edges, offsets, ids
    )
    move_counts = np.zeros(size, dtype=np.int64)
    move_counts[blocked] = counts
    new_paths = {
        int(pair): sweet_paths.path(slot)
        for slot, pair in enumerate(blocked.tolist())
        if found[slot]
    }
    return _obstructing_result(
        evaluation, blocked, new_paths, move_counts, move_fls, move_from, move_to, TEXT
    )


#: Pairs below which Move Obstructing's moves are not split between threads.
_PAIRS_PER_PART = 256


def _text_moves_in_parts(
    points: FloatArray,
    radius: float,
    grid: Grid,
    paths: Paths,
    edge: IntArray,
    edges: IntArray,
    offsets: IntArray,
    ids: IntArray,
) -> tuple[NDArray[np.bool_], IntArray, IntArray, FloatArray, FloatArray]:
    """:func:`_text_moves` of ``paths``' pairs, in parts on threads of their own, joined in order.

    Each pair starts from the original shape, so the parts are independent;
    the kernel grows its outputs as it goes and leaves the GIL.
    """
    pairs = len(paths.found)
    hop_starts = paths.offsets[:-1] - np.arange(pairs)  # every path has its hops
    parts = max(1, min(jit.get_num_threads(), pairs // _PAIRS_PER_PART))
    bounds = np.linspace(0, pairs, parts + 1).astype(np.int64)

    def part(index: int) -> tuple[NDArray[np.bool_], IntArray, IntArray, FloatArray, FloatArray]:
        lo, hi = bounds[index], bounds[index + 1]
        return _text_moves(
            points,
            radius,
            grid,
            paths.offsets[lo : hi + 1],
            paths.nodes,
            hop_starts[lo:hi],
            edge,
            edges,
            offsets,
            ids,
        )

    if parts == 1:
        return part(0)
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(parts) as pool:
        results = list(pool.map(part, range(parts)))
    return (
        np.concatenate([result[0] for result in results]),
        np.concatenate([result[1] for result in results]),
        np.concatenate([result[2] for result in results]),
        np.concatenate([result[3] for result in results]).reshape(-1, 3),
        np.concatenate([result[4] for result in results]).reshape(-1, 3),
    )


@jit.kernel(cache=True, nogil=True)
def _text_moves(
    points: FloatArray,
    radius: float,
    grid: Grid,
    path_offsets: IntArray,
    path_nodes: IntArray,
    hop_starts: IntArray,
    edge: IntArray,
    edges: IntArray,
    obstructer_offsets: IntArray,
    obstructer_ids: IntArray,
) -> tuple[NDArray[np.bool_], IntArray, IntArray, FloatArray, FloatArray]:
    """Move Obstructing as the text has it, pair after pair, compiled (see obstructing_text).

    Each pair (path p is ``path_nodes[path_offsets[p]:path_offsets[p + 1]]``, its
    hops' edge labels ``edge[hop_starts[p]:]``) starts from the original shape.
    Returns whether each pair's path is clear after its moves, each pair's
    number of moves, and every move (FLS, from, to, cm) in order.
    """
    pairs = len(path_offsets) - 1
    clear = np.zeros(pairs, dtype=np.bool_)
    counts = np.zeros(pairs, dtype=np.int64)
    move_fls = np.empty(1024, dtype=np.int64)
    move_from = np.empty((1024, 3))
    move_to = np.empty((1024, 3))
    total = 0
    moved_ids = np.empty(64, dtype=np.int64)
    moved_at = np.empty((64, 3))
    near = np.empty(len(points), dtype=np.int64)
    reach = radius - TOUCH
    for slot in range(pairs):
        path = path_nodes[path_offsets[slot] : path_offsets[slot + 1]]
        first_hop = hop_starts[slot]
        moved, began, ok = 0, total, True
        for hop in range(len(path) - 1):
            a, b = path[hop], path[hop + 1]
            row = np.searchsorted(edges, edge[first_hop + hop])
            here = obstructer_ids[obstructer_offsets[row] : obstructer_offsets[row + 1]]
            current = _current_obstructers(points, here, moved_ids, moved_at, moved, a, b, reach)
            for o in current:
                if _holds(path, o):
                    ok = False
                    break
                at = _find(moved_ids, moved, o)
                position = moved_at[at].copy() if at >= 0 else points[o].copy()
                centre = closest_on_segment(points[a], points[b], position)
                blockers = _blockers(
                    points, grid, centre, 5.0 * radius, o, moved_ids, moved_at, moved, near
                )
                target = free_circle_kernel(
                    centre,
                    points[b] - points[a],
                    position,
                    radius * (1.0 + _ASIDE),
                    blockers,
                    2.0 * radius,
                )
                if np.isnan(target[0]):
                    ok = False
                    break
                if total == len(move_fls):
                    move_fls, move_from, move_to = _grown(move_fls, move_from, move_to, total)
                move_fls[total], move_from[total], move_to[total] = o, position, target
                total += 1
                if at < 0:
                    if moved == len(moved_ids):
                        moved_ids, moved_at, _ = _grown(moved_ids, moved_at, moved_at, moved)
                    at, moved = moved, moved + 1
                    moved_ids[at] = o
                moved_at[at] = target
            if not ok:
                break
        if ok and moved:
            hops = points[path]
            ok = not near_any_segment(moved_at[:moved], hops[:-1], hops[1:], reach)
        clear[slot], counts[slot] = ok, total - began
    return clear, counts, move_fls[:total].copy(), move_from[:total].copy(), move_to[:total].copy()


@jit.kernel(cache=True, nogil=True)
def _current_obstructers(
    points: FloatArray,
    here: IntArray,
    moved_ids: IntArray,
    moved_at: FloatArray,
    moved: int,
    a: int,
    b: int,
    reach: float,
) -> IntArray:
    """The obstructers of hop a-b now, ascending: its original ones that have not moved, and
    those moved closer than ``reach`` to it."""
    current = np.empty(len(here) + moved, dtype=np.int64)
    count = 0
    for o in here:
        if _find(moved_ids, moved, o) < 0:
            current[count] = o
            count += 1
    for k in range(moved):
        if segment_gap(moved_at[k], points[a], points[b]) < reach:
            current[count] = moved_ids[k]
            count += 1
    return np.sort(current[:count])


@jit.kernel(cache=True, nogil=True)
def _blockers(
    points: FloatArray,
    grid: Grid,
    centre: FloatArray,
    reach: float,
    o: int,
    moved_ids: IntArray,
    moved_at: FloatArray,
    moved: int,
    near: IntArray,
) -> FloatArray:
    """Where the FLSs other than ``o`` stand within ``reach`` of ``centre`` after the moves,
    (B, 3) cm: ``reach`` covers every sphere that can take part of o's circle (within 3r)."""
    count = scan_ball(points, grid, centre[0], centre[1], centre[2], reach, near)
    blockers = np.empty((count + moved, 3))
    kept = 0
    for slot in range(count):
        k = near[slot]
        if k != o and _find(moved_ids, moved, k) < 0:
            blockers[kept] = points[k]
            kept += 1
    for slot in range(moved):
        if moved_ids[slot] != o:
            blockers[kept] = moved_at[slot]
            kept += 1
    return blockers[:kept]


@jit.kernel(cache=True, nogil=True)
def _find(ids: IntArray, count: int, fls: int) -> int:
    """The slot of ``fls`` among the first ``count`` of ``ids``; -1 if none."""
    for slot in range(count):
        if ids[slot] == fls:
            return slot
    return -1


@jit.kernel(cache=True, nogil=True)
def _holds(path: IntArray, fls: int) -> bool:
    """Whether ``fls`` is a node of ``path``."""
    for node in path:  # noqa: SIM110 (numba: a plain loop)
        if node == fls:
            return True
    return False


@jit.kernel(cache=True, nogil=True)
def _grown(
    ids: IntArray, first: FloatArray, second: FloatArray, used: int
) -> tuple[IntArray, FloatArray, FloatArray]:
    """``ids``, ``first`` and ``second`` twice as long, their first ``used`` rows kept."""
    grown_ids = np.empty(2 * len(ids), dtype=np.int64)
    grown_first = np.empty((2 * len(ids), 3))
    grown_second = np.empty((2 * len(ids), 3))
    grown_ids[:used] = ids[:used]
    grown_first[:used] = first[:used]
    grown_second[:used] = second[:used]
    return grown_ids, grown_first, grown_second


def obstructing_published(evaluation: PlainPairs, compat: Compat) -> HeuristicResult:
    """Move Obstructing as the reference code does it, to reproduce the published tables.

    Each obstructer's destination is found in the original shape, under
    ``compat``'s published switches; no line of sight is checked after the
    moves.

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs.
    compat : Compat
        With ``independent_moves`` on (:data:`~.compat.PUBLISHED`, or some of
        its switches).

    Returns
    -------
    HeuristicResult
    """
    hood = evaluation.hood
    points, radius = hood.swarm.points, hood.swarm.radius
    size = len(evaluation.pairs)
    blocked, sweet_paths, edge, edges, offsets, ids = _blocked_hops(evaluation)
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    tree = cKDTree(points)
    # Every move is made in the original shape: one destination per hop and obstructer.
    moves_of: dict[int, tuple[list[tuple[int, FloatArray]], bool]] = {}
    for k, label in enumerate(edges.tolist()):
        a, b = int(hood.pairs.first[label]), int(hood.pairs.second[label])
        hop_moves: list[tuple[int, FloatArray]] = []
        cleared = True
        for o in ids[offsets[k] : offsets[k + 1]].tolist():
            # A centre at exactly r obstructs, but the reference moves only those closer.
            if segment_gap(points[o], points[a], points[b]) >= radius:
                continue
            target = _published_destination(points, radius, tree, o, points[a], points[b], compat)
            if target is None:
                cleared = False
            else:
                hop_moves.append((o, target))
        moves_of[label] = (hop_moves, cleared)
    new_paths: dict[int, list[int]] = {}
    move_counts = np.zeros(size, dtype=np.int64)
    move_fls: list[int] = []
    move_to: list[FloatArray] = []
    for slot, pair in enumerate(blocked.tolist()):
        first_hop = int(sweet_paths.offsets[slot]) - slot
        hops = sweet_paths.hops[slot]
        ok = True
        for label in edge[first_hop : first_hop + hops].tolist():
            hop_moves, cleared = moves_of[label]
            if not hop_moves and cleared:
                continue  # a hop in sight, or touched only at r
            ok = cleared if compat.last_hop_decides else ok and cleared
            move_fls.extend(o for o, _ in hop_moves)
            move_to.extend(target for _, target in hop_moves)
            move_counts[pair] += len(hop_moves)
        if ok:
            new_paths[pair] = sweet_paths.path(slot)
    fls = np.array(move_fls, dtype=np.int64)
    return _obstructing_result(
        evaluation,
        blocked,
        new_paths,
        move_counts,
        fls,
        points[fls].reshape(-1, 3),
        np.array(move_to, dtype=float).reshape(-1, 3),
        compat,
    )
