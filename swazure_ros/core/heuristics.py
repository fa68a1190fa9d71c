"""Move Obstructing and Move Source (spec, sections 7 and 8).

Both are tried on every ordered blind pair whose status is BLOCKED, each
from the original shape (moves are temporary). :func:`move_obstructing` and
:func:`move_source` return a :class:`HeuristicResult`: per pair whether it
was tried and resolved, the new path and estimate, and every individual move
(which FLS went from where to where), so that a coordinator can issue the
same moves as commands. :func:`apply` folds a result into the plain run.

Conventions beyond the spec, stated once here:

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
- Move Source probes the 26 directions in the lexicographic order of their
  grid offsets (-1, -1, -1), (-1, -1, 0), ..., (1, 1, 1); among the target's
  visible sweet neighbours that succeed at one probe it takes the one with the
  smallest path length t(q, h) + t(h, j), then the smallest index.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from . import csr, jit
from .evaluate import (
    NO_PATH,
    REASON_BLOCKED,
    SWEET_PATH,
    Evaluation,
    estimates,
    merge_paths,
    summarise,
)
from .metrics import describe, pose_errors
from .paths import Paths, path_hops, paths_from_rows, shortest_paths
from .sensor import measured_vectors
from .sight import _any_within, _scan_between, obstructers

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

PLAIN = "plain"
MOVE_OBSTRUCTING = "move-obstructing"
MOVE_SOURCE = "move-source"
TECHNIQUES = (PLAIN, MOVE_OBSTRUCTING, MOVE_SOURCE)
#: Move Source's threshold T, at most: 26 probes a step, and the published study's
#: largest T is 10; beyond this the source would fly a thousand radii from its point.
MAX_THRESHOLD = 1000

#: The 26 probe directions of Move Source, unit vectors in lexicographic offset order.
DIRECTIONS = np.array(
    [offset for offset in itertools.product((-1, 0, 1), repeat=3) if any(offset)], dtype=float
)
#: The same offsets unnormalised: the published code's steps (``Compat.grid_steps``).
GRID_STEPS = DIRECTIONS.copy()
DIRECTIONS /= np.linalg.norm(DIRECTIONS, axis=1)[:, None]

#: Slack when deciding that an FLS on the obstruction-free circle clears a line of sight, cm.
_TOUCH = 1e-9
#: An FLS steps aside this fraction of r beyond the obstruction-free circle.
_ASIDE = 1e-9


def _switch(doc: str) -> Any:
    """A :class:`Compat` switch, off by default, with what it changes in ``doc``."""
    return field(default=False, metadata={"doc": doc})


@dataclass(frozen=True)
class Compat:
    """Where the heuristics follow the published reference code instead of the text.

    Every switch off is the text (spec, sections 7 and 8), the default;
    :data:`PUBLISHED` turns every one on, which is how the paper's Tables 2-4
    were computed (github.com/flyinglightspeck/Swazure, src/orchestrator.py
    and src/swarm_locator.py). Each switch's ``doc`` metadata says what it
    changes; the study's report prints them beside the two sets of numbers.
    """

    independent_moves: bool = _switch(
        "Move Obstructing: each obstructer's destination is found in the original shape, "
        "so no obstructer sees where another went, and no line of sight is checked after "
        "the moves (the text makes the moves of a pair in sequence, each collision check "
        "seeing the earlier moves, and then checks every hop). Its collision check of the "
        "ideal move looks only at FLSs within a tracking distance |o - ideal| of the "
        "obstructer, with the FLS's index o standing for its position."
    )
    last_neighbour_circle: bool = _switch(
        "Move Obstructing: when the ideal move collides, the candidate destinations are the "
        "points where the obstruction-free circle crosses the collision sphere of the LAST "
        "neighbour within 4r (by distance) only: the loop overwrites the list of crossings "
        "for every neighbour. A pair fails when that one sphere misses the circle."
    )
    clear_of_any_one: bool = _switch(
        "Move Obstructing: a crossing is accepted as a destination when it is clear of ANY "
        "ONE neighbour within 4r, not of all of them, so the FLS may move into another."
    )
    last_hop_decides: bool = _switch(
        "Move Obstructing: a pair is judged by its last obstructed hop only: the success "
        "flag is overwritten per hop, so a pair whose earlier hop cannot be cleared counts "
        "as resolved when its last obstructed hop can."
    )
    grid_steps: bool = _switch(
        "Move Source: the 26 probe directions are grid offsets times r, not unit vectors: "
        "plane diagonals step sqrt(2) r and space diagonals sqrt(3) r, so the probes reach "
        "farther than T r."
    )
    collisions_near_origin: bool = _switch(
        "Move Source: a probe collides only with FLSs within (T + 2) r of the source's "
        "original position (the text: with any FLS)."
    )
    occlusion_near_origin: bool = _switch(
        "Move Source: the line of sight from a probe q to a helper h is checked only against "
        "FLSs within |q - p_h| + 2r of the source's original position."
    )
    sweet_max_inclusive: bool = _switch(
        "Move Source: a helper exactly at the sweet range's upper bound counts as sweet at a "
        "probe (the text's ranges are half-open)."
    )
    first_helper: bool = _switch(
        "Move Source: among the target's visible sweet neighbours, the first that works at a "
        "probe is taken, in order of distance from the target; the text's engine takes the "
        "one of the shortest path t(q, h) + t(h, j)."
    )
    published_flown: bool = _switch(
        "Move Source: the flown distance adds |(q_prev - p) + delta u| per probe, where "
        "q_prev is the previous probe, and counts the probes that collided; the text adds "
        "the distance between consecutive positions actually reached."
    )

    def __post_init__(self) -> None:
        dependent = ("last_neighbour_circle", "clear_of_any_one", "last_hop_decides")
        for name in dependent:
            if getattr(self, name) and not self.independent_moves:
                raise ValueError(f"compat switch {name} needs independent_moves")

    @staticmethod
    def describe(name: str) -> str:
        """What switch ``name`` changes, one paragraph."""
        return str(Compat.__dataclass_fields__[name].metadata["doc"])

    def switches_on(self) -> list[str]:
        """The names of the switches that are on, in declaration order."""
        return [name for name in self.__dataclass_fields__ if getattr(self, name)]


#: The text's heuristics (spec, sections 7 and 8).
TEXT = Compat()
#: The published reference code's heuristics: every switch on.
PUBLISHED = Compat(**{name: True for name in Compat.__dataclass_fields__})
#: ``--compat`` choices.
COMPAT_MODES = {"text": TEXT, "published": PUBLISHED}


@dataclass(frozen=True)
class HeuristicResult:
    """Outcome of a heuristic for M ordered blind pairs; moves as a CSR over pairs."""

    technique: str
    threshold: int | None
    tried: NDArray[np.bool_]  # (M,)
    resolved: NDArray[np.bool_]  # (M,)
    paths: Paths  # the resolved pairs' sweet paths (not found elsewhere)
    estimate: FloatArray  # (M, 3), cm; nan where not resolved
    truth: FloatArray  # (M, 3), cm: p_j - p_i, or p_j - q for Move Source
    move_offsets: IntArray  # (M + 1,)
    move_fls: IntArray  # (K,), swarm index of the FLS that moved
    move_from: FloatArray  # (K, 3), cm
    move_to: FloatArray  # (K, 3), cm
    flown: FloatArray = field(default_factory=lambda: np.zeros(0))  # (M,), Move Source
    compat: Compat = TEXT

    def moves(self, pair: int) -> list[tuple[int, FloatArray, FloatArray]]:
        """The moves made for pair ``pair``: (fls, from, to), in order."""
        span = range(self.move_offsets[pair], self.move_offsets[pair + 1])
        return [(int(self.move_fls[k]), self.move_from[k], self.move_to[k]) for k in span]

    @property
    def move_distance(self) -> FloatArray:
        """Length of every individual move, cm: (K,)."""
        return np.asarray(np.linalg.norm(self.move_to - self.move_from, axis=1))


def check_technique(technique: str) -> str:
    """Return ``technique`` if valid, else raise ValueError listing the valid ones."""
    if technique not in TECHNIQUES:
        raise ValueError(
            f"unknown technique {technique!r}; expected one of {', '.join(TECHNIQUES)}"
        )
    return technique


def free_circle_point(
    centre: FloatArray,
    normal: FloatArray,
    toward: FloatArray,
    radius: float,
    blockers: FloatArray,
    block_radius: float,
) -> FloatArray | None:
    """The point of a circle nearest ``toward`` that is not strictly inside any blocking sphere.

    The circle has centre ``centre``, radius ``radius`` and lies in the plane
    through ``centre`` perpendicular to ``normal``; each row of ``blockers``
    (B, 3) is the centre of a sphere of radius ``block_radius`` whose interior
    is removed. Exact: each sphere removes one open arc, computed in closed
    form. Returns None when nothing of the circle remains. Units: cm.
    """
    point: FloatArray = _free_circle_kernel(
        np.asarray(centre, dtype=np.float64),
        np.asarray(normal, dtype=np.float64),
        np.asarray(toward, dtype=np.float64),
        float(radius),
        np.ascontiguousarray(blockers, dtype=np.float64).reshape(-1, 3),
        float(block_radius),
    )
    return None if np.isnan(point[0]) else point


@jit.kernel(cache=True)
def _wrap(angle: float) -> float:
    return (angle + np.pi) % (2 * np.pi) - np.pi


@jit.kernel(cache=True)
def _free_circle_kernel(
    centre: FloatArray,
    normal: FloatArray,
    toward: FloatArray,
    radius: float,
    blockers: FloatArray,
    block_radius: float,
) -> FloatArray:
    """free_circle_point's work; a nan point means nothing of the circle is free."""
    normal = normal / np.sqrt(normal @ normal)
    offset = toward - centre
    offset = offset - (offset @ normal) * normal
    if np.sqrt(offset @ offset) < 1e-12 * max(radius, 1.0):
        # Exactly on the line: any direction is nearest; take a fixed one.
        axis = np.zeros(3)
        axis[np.argmin(np.abs(normal))] = 1.0
        offset = np.cross(normal, axis)
    first = offset / np.sqrt(offset @ offset)
    second = np.cross(normal, first)
    # |q(θ) - s|² < R²  <=>  A cos θ + B sin θ < m, with q(θ) = c + r (cos θ e1 + sin θ e2).
    phases = np.empty(len(blockers))
    halves = np.empty(len(blockers))
    arcs = 0
    for k in range(len(blockers)):
        relative = centre - blockers[k]
        a, b = relative @ first, relative @ second
        m = -(relative @ relative + radius**2 - block_radius**2) / (2 * radius)
        rho = np.hypot(a, b)
        if (rho == 0 and m > 0) or (rho > 0 and m > rho):
            return np.full(3, np.nan)  # this sphere covers the whole circle
        if rho > 0 and m > -rho:
            phases[arcs] = np.arctan2(b, a) + np.pi  # centre of the removed arc
            halves[arcs] = np.pi - np.arccos(min(max(m / rho, -1.0), 1.0))
            arcs += 1
    # Candidates: θ = 0 (the ideal move) and every arc end; nearest = smallest |θ|, then +θ.
    best = np.nan
    for candidate in range(2 * arcs + 1):
        if candidate == 0:
            theta = 0.0
        elif candidate <= arcs:
            theta = _wrap(phases[candidate - 1] - halves[candidate - 1])
        else:
            theta = _wrap(phases[candidate - 1 - arcs] + halves[candidate - 1 - arcs])
        free = True
        for k in range(arcs):
            if abs(_wrap(theta - phases[k])) < halves[k] - 1e-12:
                free = False
                break
        if free and (
            np.isnan(best) or abs(theta) < abs(best) or (abs(theta) == abs(best) and theta > best)
        ):
            best = theta
    if np.isnan(best):
        return np.full(3, np.nan)
    point: FloatArray = centre + radius * (np.cos(best) * first + np.sin(best) * second)
    return point


def circle_sphere_crossings(
    centre: FloatArray,
    normal: FloatArray,
    radius: float,
    sphere: FloatArray,
    sphere_radius: float,
) -> FloatArray:
    """Points (0 to 2, 3) where a circle meets a sphere's surface, cm.

    The circle has centre ``centre`` (3,), radius ``radius`` and lies in the
    plane through ``centre`` perpendicular to ``normal`` (3,); the sphere has
    centre ``sphere`` (3,) and radius ``sphere_radius``. A tangent circle gives
    its one point twice.
    """
    normal = normal / np.linalg.norm(normal)
    axis = np.zeros(3)
    axis[np.argmin(np.abs(normal))] = 1.0
    first = np.cross(normal, axis)
    first /= np.linalg.norm(first)
    second = np.cross(normal, first)
    # |c + r (cos θ e1 + sin θ e2) - s|² = R²  <=>  a cos θ + b sin θ = m.
    relative = centre - sphere
    a, b = float(relative @ first), float(relative @ second)
    m = (sphere_radius**2 - relative @ relative - radius**2) / (2.0 * radius)
    rho = float(np.hypot(a, b))
    if rho == 0.0 or abs(m) > rho:
        return np.zeros((0, 3))
    phase, half = np.arctan2(b, a), np.arccos(m / rho)
    theta = np.array([phase - half, phase + half])
    return np.asarray(
        centre + radius * (np.cos(theta)[:, None] * first + np.sin(theta)[:, None] * second)
    )


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
    centre = _closest_on_segment(start, end, position)
    offset = position - centre
    ideal = position + (radius / np.linalg.norm(offset) - 1.0) * offset
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


def _closest_on_segment(start: FloatArray, end: FloatArray, point: FloatArray) -> FloatArray:
    direction = end - start
    along = float((point - start) @ direction / (direction @ direction))
    return np.asarray(start + min(max(along, 0.0), 1.0) * direction)


def _blocked_pairs(evaluation: Evaluation) -> IntArray:
    pairs = evaluation.pairs
    return np.flatnonzero((pairs.reason == REASON_BLOCKED) & (pairs.status != SWEET_PATH))


def _empty_result(technique: str, threshold: int | None, size: int) -> dict[str, Any]:
    return {
        "technique": technique,
        "threshold": threshold,
        "tried": np.zeros(size, dtype=bool),
        "resolved": np.zeros(size, dtype=bool),
        "estimate": np.full((size, 3), np.nan),
        "truth": np.full((size, 3), np.nan),
    }


def _blocked_hops(
    evaluation: Evaluation,
) -> tuple[IntArray, Paths, IntArray, IntArray, IntArray, IntArray]:
    """The BLOCKED pairs, their S_all paths, and the obstructers of each hop's edge.

    Returns (blocked pairs (B,), their paths, the edge label of every hop
    (H,), the distinct labels (E,), and the obstructers in the original shape
    as a CSR over those labels: offsets (E + 1,), swarm indices).
    """
    hood, pairs = evaluation.hood, evaluation.pairs
    blocked = _blocked_pairs(evaluation)
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
    evaluation: Evaluation,
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
    result = _empty_result(MOVE_OBSTRUCTING, None, size)
    result["tried"][blocked] = True
    resolved = np.zeros(size, dtype=bool)
    resolved[list(new_paths)] = True
    result["resolved"] = resolved
    paths = paths_from_rows(size, new_paths)
    estimate, _, _ = estimates(evaluation.hood, paths)
    result["estimate"][resolved] = estimate[resolved]
    result["truth"][resolved] = evaluation.pairs.truth[resolved]
    return HeuristicResult(
        paths=paths,
        move_offsets=csr.offsets(move_counts),
        move_fls=move_fls,
        move_from=move_from,
        move_to=move_to,
        compat=compat,
        **result,
    )


def move_obstructing(evaluation: Evaluation, compat: Compat = TEXT) -> HeuristicResult:
    """Move Obstructing (section 7) on every BLOCKED pair of a plain evaluation."""
    if compat.independent_moves:
        return _move_obstructing_independently(evaluation, compat)
    points, radius = evaluation.hood.swarm.points, evaluation.hood.swarm.radius
    size = len(evaluation.pairs)
    blocked, sweet_paths, edge, edges, offsets, ids = _blocked_hops(evaluation)
    original = {
        int(e): ids[offsets[k] : offsets[k + 1]].tolist() for k, e in enumerate(edges.tolist())
    }
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    tree = cKDTree(points)
    new_paths: dict[int, list[int]] = {}
    move_counts = np.zeros(size, dtype=np.int64)
    move_fls: list[int] = []
    move_from: list[FloatArray] = []
    move_to: list[FloatArray] = []
    for slot, pair in enumerate(blocked.tolist()):
        path = sweet_paths.path(slot)
        moved: dict[int, FloatArray] = {}
        moves: list[tuple[int, FloatArray, FloatArray]] = []
        ok = True
        # Every blocked pair has an S_all path, so path `slot` has hops from here on.
        first_hop = int(sweet_paths.offsets[slot]) - slot
        for hop, (a, b) in enumerate(itertools.pairwise(path)):
            here = original[int(edge[first_hop + hop])]
            current = [o for o in here if o not in moved]
            if moved:
                where = np.array(list(moved.values())).reshape(-1, 3)
                near = _near_segment(where, points[a], points[b], radius - _TOUCH)
                current += [o for o, close in zip(moved, near.tolist(), strict=True) if close]
            for o in sorted(set(current)):
                if o in path:
                    ok = False
                    break
                position = moved.get(o, points[o])
                centre = _closest_on_segment(points[a], points[b], position)
                near = tree.query_ball_point(centre, 5.0 * radius)
                others = [k for k in near if k != o and k not in moved]
                blockers = np.concatenate(
                    [
                        points[others].reshape(-1, 3),
                        np.array([p for k, p in moved.items() if k != o]).reshape(-1, 3),
                    ]
                )
                target = free_circle_point(
                    centre,
                    points[b] - points[a],
                    position,
                    radius * (1.0 + _ASIDE),
                    blockers,
                    2.0 * radius,
                )
                if target is None:
                    ok = False
                    break
                moves.append((o, position, target))
                moved[o] = target
            if not ok:
                break
        if ok and moved:
            hops = points[np.asarray(path, dtype=np.int64)]
            where = np.array(list(moved.values())).reshape(-1, 3)
            ok = not _near_a_segment(where, hops[:-1], hops[1:], radius - _TOUCH)
        for o, old, new in moves:
            move_fls.append(o)
            move_from.append(old)
            move_to.append(new)
        move_counts[pair] = len(moves)
        if ok:
            new_paths[pair] = path
    return _obstructing_result(
        evaluation,
        blocked,
        new_paths,
        move_counts,
        np.array(move_fls, dtype=np.int64),
        np.array(move_from, dtype=float).reshape(-1, 3),
        np.array(move_to, dtype=float).reshape(-1, 3),
        TEXT,
    )


def _move_obstructing_independently(evaluation: Evaluation, compat: Compat) -> HeuristicResult:
    """Move Obstructing as the reference code does it (``compat.independent_moves``)."""
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
            if _gap(points[o], points[a], points[b]) >= radius:
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


@jit.kernel(cache=True, parallel=True)
def _probe_kernel(
    points: FloatArray,
    radius: float,
    sweet_min: float,
    sweet_max: float,
    sources: IntArray,
    targets: IntArray,
    visible_indptr: IntArray,
    visible_indices: IntArray,
    directions: FloatArray,
    threshold: int,
    origin: FloatArray,
    cell: float,
    shape: IntArray,
    cell_start: IntArray,
    members: IntArray,
    collision_reach: float,
    occlusion_near_origin: bool,
    sweet_max_inclusive: bool,
    first_helper: bool,
    published_flown: bool,
) -> tuple[IntArray, FloatArray, FloatArray]:
    """Per pair: the sweet neighbour reached (-1 if none), probe position, distance flown.

    The last five arguments are :class:`Compat`'s Move Source switches;
    ``collision_reach`` is inf when collisions count everywhere.
    """
    pairs = len(sources)
    helper = np.full(pairs, -1, dtype=np.int64)
    probe = np.full((pairs, 3), np.nan)
    flown = np.zeros(pairs)
    for pair in jit.prange(pairs):
        i, j = sources[pair], targets[pair]
        found = np.empty(len(points) if occlusion_near_origin else 1, dtype=np.int64)
        alive = np.ones(len(directions), dtype=np.bool_)
        x, y, z = points[i, 0], points[i, 1], points[i, 2]
        for delta in range(1, threshold + 1):
            for d in range(len(directions)):
                if not alive[d]:
                    continue
                step = delta * radius
                qx = points[i, 0] + step * directions[d, 0]
                qy = points[i, 1] + step * directions[d, 1]
                qz = points[i, 2] + step * directions[d, 2]
                if published_flown:
                    # |(q_prev - p) + delta u|, before the collision check, as published.
                    fx = x - points[i, 0] + qx - points[i, 0]
                    fy = y - points[i, 1] + qy - points[i, 1]
                    fz = z - points[i, 2] + qz - points[i, 2]
                    flown[pair] += np.sqrt(fx * fx + fy * fy + fz * fz)
                    x, y, z = qx, qy, qz
                # Collision: any other FLS centre closer than 2r to q.
                collides = _any_within(
                    points,
                    qx,
                    qy,
                    qz,
                    2.0 * radius,
                    i,
                    origin,
                    cell,
                    shape,
                    cell_start,
                    members,
                    points[i],
                    collision_reach,
                )
                if collides:
                    alive[d] = False
                    continue
                if not published_flown:
                    flown[pair] += np.sqrt((qx - x) ** 2 + (qy - y) ** 2 + (qz - z) ** 2)
                    x, y, z = qx, qy, qz
                best, best_length = -1, np.inf
                for slot in range(visible_indptr[j], visible_indptr[j + 1]):
                    h = visible_indices[slot]
                    if h == i:
                        continue
                    hx, hy, hz = points[h, 0], points[h, 1], points[h, 2]
                    tracking = np.sqrt((hx - qx) ** 2 + (hy - qy) ** 2 + (hz - qz) ** 2)
                    tracking -= 2.0 * radius
                    if tracking < sweet_min or tracking > sweet_max:
                        continue
                    if tracking == sweet_max and not sweet_max_inclusive:
                        continue
                    hop = (
                        np.sqrt(
                            (hx - points[j, 0]) ** 2
                            + (hy - points[j, 1]) ** 2
                            + (hz - points[j, 2]) ** 2
                        )
                        - 2.0 * radius
                    )
                    total = (0.0 + tracking) + hop
                    if total >= best_length:
                        continue
                    hits = _scan_between(
                        points,
                        radius,
                        qx,
                        qy,
                        qz,
                        hx,
                        hy,
                        hz,
                        i,
                        h,
                        origin,
                        cell,
                        shape,
                        cell_start,
                        members,
                        found,
                        not occlusion_near_origin,
                    )
                    if occlusion_near_origin:
                        # As published: only FLSs within |q - p_h| + 2r of the source's origin.
                        reach = np.sqrt((hx - qx) ** 2 + (hy - qy) ** 2 + (hz - qz) ** 2)
                        reach += 2.0 * radius
                        near = 0
                        for slot_found in range(hits):
                            k = found[slot_found]
                            ex = points[k, 0] - points[i, 0]
                            ey = points[k, 1] - points[i, 1]
                            ez = points[k, 2] - points[i, 2]
                            if np.sqrt(ex * ex + ey * ey + ez * ez) <= reach:
                                near += 1
                        hits = near
                    if hits == 0:
                        best, best_length = h, total
                        if first_helper:
                            break
                if best >= 0:
                    helper[pair] = best
                    probe[pair, 0], probe[pair, 1], probe[pair, 2] = qx, qy, qz
                    break
            if helper[pair] >= 0:
                break
    return helper, probe, flown


def _nearest_first(points: FloatArray, indptr: IntArray, indices: IntArray) -> IntArray:
    """Each CSR row's column indices by distance from the row's point, then by index."""
    rows = csr.run_of(indptr)
    distance = np.linalg.norm(points[indices] - points[rows], axis=1)
    return np.asarray(indices[np.lexsort((indices, distance, rows))], dtype=np.int64)


def move_source(evaluation: Evaluation, threshold: int, compat: Compat = TEXT) -> HeuristicResult:
    """Move Source (section 8) with probe steps delta = 1..``threshold`` on every BLOCKED pair."""
    if not 1 <= threshold <= MAX_THRESHOLD:
        raise ValueError(f"threshold must be 1 to {MAX_THRESHOLD} steps, got {threshold}")
    hood, pairs = evaluation.hood, evaluation.pairs
    swarm, sensor, grid = hood.swarm, hood.sensor, hood.grid
    size = len(pairs)
    result = _empty_result(MOVE_SOURCE, threshold, size)
    blocked = _blocked_pairs(evaluation)
    result["tried"][blocked] = True
    visible = hood.sweet_visible
    helpers = visible.indices.astype(np.int64)
    if compat.first_helper:
        helpers = _nearest_first(swarm.points, visible.indptr, helpers)
    reach = (threshold + 2) * swarm.radius if compat.collisions_near_origin else np.inf
    helper, probe, flown_blocked = _probe_kernel(
        swarm.points,
        swarm.radius,
        sensor.sweet_min,
        sensor.sweet_max,
        pairs.source[blocked],
        pairs.target[blocked],
        visible.indptr,
        helpers,
        GRID_STEPS if compat.grid_steps else DIRECTIONS,
        int(threshold),
        grid.origin,
        grid.cell,
        grid.shape,
        grid.cell_start,
        grid.members,
        float(reach),
        compat.occlusion_near_origin,
        compat.sweet_max_inclusive,
        compat.first_helper,
        compat.published_flown,
    )
    success = helper >= 0
    resolved_pairs = blocked[success]
    resolved = np.zeros(size, dtype=bool)
    resolved[resolved_pairs] = True
    flown = np.zeros(size)
    flown[blocked] = flown_blocked
    # Hops q -> h -> j, measured with the source at its probe position q.
    extended = np.vstack([swarm.points, probe[success]])
    moved_source = swarm.size + np.arange(len(resolved_pairs))
    middle = helper[success]
    first_hop = measured_vectors(sensor, extended, swarm.radius, moved_source, middle)
    second_hop = measured_vectors(
        sensor, extended, swarm.radius, middle, pairs.target[resolved_pairs]
    )
    result["resolved"] = resolved
    result["estimate"][resolved_pairs] = first_hop + second_hop
    result["truth"][resolved_pairs] = swarm.points[pairs.target[resolved_pairs]] - probe[success]
    rows = {
        int(pair): [int(pairs.source[pair]), int(h), int(pairs.target[pair])]
        for pair, h in zip(resolved_pairs, middle)
    }
    move_counts = np.zeros(size, dtype=np.int64)
    move_counts[resolved_pairs] = 1
    return HeuristicResult(
        paths=paths_from_rows(size, rows),
        move_offsets=csr.offsets(move_counts),
        move_fls=pairs.source[resolved_pairs].astype(np.int64),
        move_from=swarm.points[pairs.source[resolved_pairs]].reshape(-1, 3),
        move_to=probe[success].reshape(-1, 3),
        flown=flown,
        compat=compat,
        **result,
    )


def apply(evaluation: Evaluation, heuristic: HeuristicResult) -> Evaluation:
    """The plain evaluation with the heuristic's resolved pairs made SWEET; summary extended."""
    pairs = evaluation.pairs
    resolved = heuristic.resolved
    status = pairs.status.copy()
    status[resolved] = SWEET_PATH
    plain = Paths(
        pairs.status != NO_PATH, pairs.hops, pairs.path_length, pairs.offsets, pairs.nodes
    )
    moved = heuristic.paths
    # A pair may keep its planned path without being resolved (its walk failed: walked()).
    resolved_nodes = moved.nodes[np.repeat(resolved, np.diff(moved.offsets))]
    paths = merge_paths(
        plain,
        Paths(
            moved.found[resolved],
            moved.hops[resolved],
            moved.length[resolved],
            moved.offsets,
            resolved_nodes,
        ),
        resolved,
    )
    hops = np.where(paths.found, paths.hops, 0)
    estimate = np.where(resolved[:, None], heuristic.estimate, pairs.estimate)
    truth = np.where(resolved[:, None], heuristic.truth, pairs.truth)
    sweet_hops = np.where(resolved, hops, pairs.sweet_hops)
    decaying_hops = np.where(resolved, 0, pairs.decaying_hops)
    length = pairs.path_length.copy()
    length[resolved] = np.nan
    errors = pose_errors(estimate, truth)
    updated = replace(
        pairs,
        status=status,
        hops=hops,
        sweet_hops=sweet_hops,
        decaying_hops=decaying_hops,
        path_length=length,
        offsets=paths.offsets,
        nodes=paths.nodes,
        estimate=estimate,
        truth=truth,
        distance_error=errors[0],
        alpha=errors[1],
        theta=errors[2],
        phi=errors[3],
        # A resolved pair's path was measured in a moved swarm: no prediction of its error.
        predicted_error=np.where(resolved, np.nan, pairs.predicted_error),
        fused_paths=np.where(paths.found, 1, 0).astype(np.int64),
    )
    summary = summarise(evaluation.hood, evaluation.policy, updated)
    summary["seconds"] = evaluation.summary.get("seconds")
    summary.update(heuristic_summary(heuristic))
    summary["parameters"]["technique"] = heuristic.technique
    summary["parameters"]["threshold"] = heuristic.threshold
    return replace(evaluation, pairs=updated, summary=summary)


@jit.kernel(cache=True, nogil=True, error_model="numpy")
def _gap(point: FloatArray, start: FloatArray, end: FloatArray) -> float:
    """Distance of ``point`` (3,) to the segment start-end (3,)-(3,), cm."""
    dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
    ox, oy, oz = point[0] - start[0], point[1] - start[1], point[2] - start[2]
    along = min(max((ox * dx + oy * dy + oz * dz) / (dx * dx + dy * dy + dz * dz), 0.0), 1.0)
    gx = point[0] - (start[0] + along * dx)
    gy = point[1] - (start[1] + along * dy)
    gz = point[2] - (start[2] + along * dz)
    return float(np.sqrt(gx * gx + gy * gy + gz * gz))


@jit.kernel(cache=True, nogil=True)
def _near_a_segment(
    points: FloatArray, starts: FloatArray, ends: FloatArray, reach: float
) -> bool:
    """True when a point (K, 3) is closer than ``reach`` to a segment (S, 3)-(S, 3), cm."""
    for s in range(len(starts)):
        for k in range(len(points)):
            if _gap(points[k], starts[s], ends[s]) < reach:
                return True
    return False


@jit.kernel(cache=True, nogil=True)
def _near_segment(
    points: FloatArray, start: FloatArray, end: FloatArray, reach: float
) -> NDArray[np.bool_]:
    """(K,) whether each point (K, 3) is closer than ``reach`` to the segment start-end, cm."""
    near = np.zeros(len(points), dtype=np.bool_)
    for k in range(len(points)):
        near[k] = _gap(points[k], start, end) < reach
    return near


@jit.kernel(cache=True, nogil=True)
def _closer_than(first: FloatArray, second: FloatArray, distance: float) -> bool:
    """True when a point of ``first`` (K, 3) is closer than ``distance`` to one of ``second``."""
    for k in range(len(first)):
        for m in range(len(second)):
            gx, gy = first[k, 0] - second[m, 0], first[k, 1] - second[m, 1]
            gz = first[k, 2] - second[m, 2]
            if np.sqrt(gx * gx + gy * gy + gz * gz) < distance:
                return True
    return False


@dataclass
class _Batch:
    pairs: list[int]
    moved: dict[int, tuple[float, float, float]]  # FLS -> where it moves to, cm
    starts: list[FloatArray]  # hop segments of the batch's paths, (H, 3) per pair, cm
    ends: list[FloatArray]
    _arrays: tuple[IntArray, FloatArray, FloatArray, FloatArray] | None = None

    def arrays(self) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
        """Moved FLSs (M,), where they go (M, 3), hop starts and ends (S, 3) each, cm."""
        # Cached: a batch is looked at by many pairs between two that join it.
        if self._arrays is None:
            self._arrays = (
                np.fromiter(self.moved, dtype=np.int64, count=len(self.moved)),
                np.array(list(self.moved.values()), dtype=np.float64).reshape(-1, 3),
                np.concatenate(self.starts) if self.starts else np.zeros((0, 3)),
                np.concatenate(self.ends) if self.ends else np.zeros((0, 3)),
            )
        return self._arrays

    def join(
        self, pair: int, moved: dict[int, tuple[float, float, float]], where: FloatArray
    ) -> None:
        """Add ``pair``, its moves and its hops between ``where`` (H + 1, 3), cm."""
        self.pairs.append(pair)
        self.moved.update(moved)
        self.starts.append(where[:-1])
        self.ends.append(where[1:])
        self._arrays = None


def move_batches(evaluation: Evaluation, heuristic: HeuristicResult) -> list[IntArray]:
    """A heuristic's resolved pairs in groups whose moves can be made at once.

    A pair joins the first group (in pair order) where no FLS it moves goes
    elsewhere for another pair or lies on another pair's path, no FLS on its
    path moves for another pair, no FLS moved by the group stands within r
    of a hop of another pair, and no two FLSs moved for different pairs come
    closer than 2r. Hops run between where the path's FLSs stand once the
    pair's moves are made (Move Source's source at its probe position). Every
    pair of a group then sees its hops exactly as it would alone: its own
    moves made, nothing new in sight.
    """
    points, radius = evaluation.hood.swarm.points, evaluation.hood.swarm.radius
    paths = heuristic.paths
    batches: list[_Batch] = []
    # Per FLS and batch: does it lie on a path of the batch, and where does it move
    # in the batch (an index into its destinations; -1: it stays). A pair's
    # conflicts by FLS are then a few rows of these tables, not a look into every batch.
    capacity = 64
    on_path = np.zeros((len(points), capacity), dtype=bool)
    moves_to = np.full((len(points), capacity), -1, dtype=np.int32)
    destinations: list[dict[tuple[float, float, float], int]] = [{} for _ in points]
    is_mover = np.zeros(len(points), dtype=bool)  # the FLSs the pair at hand moves
    for pair in np.flatnonzero(heuristic.resolved).tolist():
        path = paths.nodes[paths.offsets[pair] : paths.offsets[pair + 1]]
        moved: dict[int, tuple[float, float, float]] = {
            fls: (float(to[0]), float(to[1]), float(to[2])) for fls, _, to in heuristic.moves(pair)
        }
        where = np.array([moved.get(fls, points[fls]) for fls in path.tolist()], dtype=np.float64)
        starts, ends = where[:-1], where[1:]
        count = len(batches)
        excluded = (moves_to[path, :count] >= 0).any(axis=0)
        movers = np.fromiter(moved, dtype=np.int64, count=len(moved))
        is_mover[movers] = True
        if len(movers):
            going_to = np.array(
                [
                    destinations[fls].setdefault(to, len(destinations[fls]))
                    for fls, to in moved.items()
                ]
            )
            elsewhere = moves_to[movers, :count]
            excluded |= on_path[movers, :count].any(axis=0)
            excluded |= ((elsewhere >= 0) & (elsewhere != going_to[:, None])).any(axis=0)
        destination = np.array(list(moved.values()), dtype=np.float64).reshape(-1, 3)
        for index in np.flatnonzero(~excluded).tolist():
            batch = batches[index]
            ids, goes_to, batch_starts, batch_ends = batch.arrays()
            mine = destination[moves_to[movers, index] < 0]
            theirs = goes_to[~is_mover[ids]]
            # Compiled, and each check stops at its first conflict: most candidate
            # batches of a pair conflict, and this loop is most of the planning.
            if (
                _closer_than(mine, theirs, 2.0 * radius)
                or _near_a_segment(mine, batch_starts, batch_ends, radius - _TOUCH)
                or _near_a_segment(theirs, starts, ends, radius - _TOUCH)
            ):
                continue
            break
        else:
            index, batch = count, _Batch([], {}, [], [])
            batches.append(batch)
            if count == capacity:
                capacity *= 2
                on_path = np.pad(on_path, ((0, 0), (0, capacity - count)))
                moves_to = np.pad(moves_to, ((0, 0), (0, capacity - count)), constant_values=-1)
        is_mover[movers] = False
        batch.join(pair, moved, where)
        on_path[path, index] = True
        for fls, to in moved.items():
            moves_to[fls, index] = destinations[fls][to]
    return [np.array(batch.pairs, dtype=np.int64) for batch in batches]


def walked(heuristic: HeuristicResult, vectors: dict[int, FloatArray]) -> HeuristicResult:
    """``heuristic`` with its resolved pairs re-measured: {pair: summed vector (3,), cm}.

    A resolved pair whose path walk did not arrive is not resolved after all.
    """
    arrived = np.zeros(len(heuristic.resolved), dtype=bool)
    arrived[list(vectors)] = True
    resolved = heuristic.resolved & arrived
    estimate = np.full_like(heuristic.estimate, np.nan)
    for pair in np.flatnonzero(resolved).tolist():
        estimate[pair] = vectors[pair]
    truth = np.where(resolved[:, None], heuristic.truth, np.nan)
    return replace(heuristic, resolved=resolved, estimate=estimate, truth=truth)


def run_technique(
    evaluation: Evaluation, technique: str, threshold: int = 10, compat: Compat = TEXT
) -> tuple[Evaluation, HeuristicResult | None]:
    """Apply ``technique`` to a plain evaluation; plain returns it unchanged, with no result."""
    if check_technique(technique) == PLAIN:
        return evaluation, None
    if technique == MOVE_OBSTRUCTING:
        heuristic = move_obstructing(evaluation, compat)
    else:
        heuristic = move_source(evaluation, threshold, compat)
    return apply(evaluation, heuristic), heuristic


def heuristic_summary(heuristic: HeuristicResult) -> dict[str, Any]:
    """The summary fields of a heuristic (section 6): tried, resolved and move distances.

    ``moved_distance`` is per move, of the resolved pairs only; the moves of
    pairs that were tried and still failed are ``failed_moved_distance``.
    ``moved_per_resolved_pair`` is what each resolved pair moved in all (the
    published Table 3's metric), cm.
    """
    moved = heuristic.move_distance
    pairs = len(heuristic.resolved)
    owner = csr.run_of(heuristic.move_offsets)  # pair of each move
    of_resolved = heuristic.resolved[owner]
    resolved = np.flatnonzero(heuristic.resolved)
    totals = np.bincount(owner, weights=moved, minlength=pairs)[resolved]
    fields: dict[str, Any] = {
        "technique": heuristic.technique,
        "threshold": heuristic.threshold,
        "tried_pairs": int(heuristic.tried.sum()),
        "resolved_pairs": len(resolved),
        "moved_distance": describe(moved[of_resolved]),
        "failed_moved_distance": describe(moved[~of_resolved]),
        "moved_per_resolved_pair": describe(totals),
        "compat": heuristic.compat.switches_on(),
    }
    if heuristic.technique == MOVE_SOURCE:
        fields["flown_distance"] = describe(heuristic.flown[heuristic.tried])
        fields["displacement"] = describe(moved[of_resolved])
    return fields
