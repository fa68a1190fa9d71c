"""Move Source (spec, section 8): the source probes around itself for a common sweet neighbour.

Move Source probes the 26 directions in the lexicographic order of their
grid offsets (-1, -1, -1), (-1, -1, 0), ..., (1, 1, 1); among the target's
visible sweet neighbours that succeed at one probe it takes the one with the
smallest path length t(q, h) + t(h, j), then the smallest index. The text's
and the published behaviours differ in the rules of one probe
(:class:`ProbeRules`, from :class:`~.compat.Compat`). The spec's probe does not
check that the source's own body at its probe point q leaves the helper's
view of the target clear; with ``source_body`` it does, as the swarm flies it
(docs/protocol.md, "The heuristics, made by the swarm").
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

from ...core.arrays import FloatArray, IntArray
from .. import csr, jit
from ..geometry import Swarm
from ..grid import Grid, blocks, scan_between
from ..hop_errors import measured_vectors
from ..path_arrays import paths_from_rows
from ..sight import any_within
from .compat import TEXT, Compat
from .result import (
    MAX_THRESHOLD,
    MOVE_SOURCE,
    HeuristicResult,
    PairFindings,
    PlainPairs,
    blocked_pairs,
)

#: The 26 probe directions of Move Source, unit vectors in lexicographic offset order.
DIRECTIONS = np.array(
    [offset for offset in itertools.product((-1, 0, 1), repeat=3) if any(offset)], dtype=float
)


#: The same offsets unnormalised: the published code's steps (``Compat.grid_steps``).
GRID_STEPS = DIRECTIONS.copy()


DIRECTIONS /= np.linalg.norm(DIRECTIONS, axis=1)[:, None]


class ProbeRules(NamedTuple):
    """The rules of one probe, the text's or the published code's: one kernel argument."""

    collision_reach: float  # cm from the source's origin; inf: collisions count everywhere
    occlusion_near_origin: bool  # Compat.occlusion_near_origin
    sweet_max_inclusive: bool  # Compat.sweet_max_inclusive
    first_helper: bool  # Compat.first_helper
    published_flown: bool  # Compat.published_flown
    source_body: bool  # the source's body at q may block the helper's view of the target


def probe_rules(compat: Compat, collision_reach: float, source_body: bool = False) -> ProbeRules:
    """The probe rules of ``compat``'s Move Source switches.

    Parameters
    ----------
    compat : Compat
    collision_reach : float, cm
        How far from the source's original position another FLS counts for a
        probe's collision; inf for every FLS (the text).
    source_body : bool, default False
        A helper counts only when the source's body at the probe point leaves
        its view of the target clear (the spec does not check it).

    Returns
    -------
    ProbeRules
        One argument for the probe kernel.
    """
    return ProbeRules(
        collision_reach,
        compat.occlusion_near_origin,
        compat.sweet_max_inclusive,
        compat.first_helper,
        compat.published_flown,
        source_body,
    )


class ProbeScene(NamedTuple):
    """The swarm as a probe sees it, but for its grid: one kernel argument.

    The grid travels beside it: numba's parallel loops take no nested tuple.
    """

    points: FloatArray  # (N, 3), cm
    radius: float  # FLS radius r, cm
    sweet_min: float  # sweet tracking distances, cm
    sweet_max: float
    visible_indptr: IntArray  # (N + 1,), CSR of each FLS's visible sweet neighbours
    visible_indices: IntArray


@jit.kernel(cache=True, parallel=True)
def _probe_kernel(
    scene: ProbeScene,
    grid: Grid,
    sources: IntArray,
    targets: IntArray,
    directions: FloatArray,
    threshold: int,
    rules: ProbeRules,
) -> tuple[IntArray, FloatArray, FloatArray]:
    """Per pair: the sweet neighbour reached (-1 if none), probe position, distance flown."""
    points = scene.points
    radius = scene.radius
    occlusion_near_origin = rules.occlusion_near_origin
    published_flown = rules.published_flown
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
                collides = any_within(
                    points,
                    qx,
                    qy,
                    qz,
                    2.0 * radius,
                    i,
                    grid,
                    points[i],
                    rules.collision_reach,
                )
                if collides:
                    alive[d] = False
                    continue
                if not published_flown:
                    flown[pair] += np.sqrt((qx - x) ** 2 + (qy - y) ** 2 + (qz - z) ** 2)
                    x, y, z = qx, qy, qz
                best = _best_helper(scene, grid, rules, i, j, qx, qy, qz, found)
                if best >= 0:
                    helper[pair] = best
                    probe[pair, 0], probe[pair, 1], probe[pair, 2] = qx, qy, qz
                    break
            if helper[pair] >= 0:
                break
    return helper, probe, flown


@jit.kernel(cache=True, nogil=True)
def _best_helper(
    scene: ProbeScene,
    grid: Grid,
    rules: ProbeRules,
    i: int,
    j: int,
    qx: float,
    qy: float,
    qz: float,
    found: IntArray,
) -> int:
    """The sweet neighbour of j that source i at probe position q, cm, reaches; -1 if none.

    ``found`` is scratch for the obstructers of one segment.
    """
    points, radius, sweet_min, sweet_max, visible_indptr, visible_indices = scene
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
        if tracking == sweet_max and not rules.sweet_max_inclusive:
            continue
        hop = (
            np.sqrt((hx - points[j, 0]) ** 2 + (hy - points[j, 1]) ** 2 + (hz - points[j, 2]) ** 2)
            - 2.0 * radius
        )
        total = (0.0 + tracking) + hop
        if total >= best_length:
            continue
        if rules.source_body and _blocks_at(points, radius, qx, qy, qz, h, j):
            continue  # the source, standing at q, hides the target from h
        near_origin = rules.occlusion_near_origin
        at, to = (qx, qy, qz), (hx, hy, hz)
        hits = scan_between(points, radius, at, to, i, h, grid, found, not near_origin)
        if near_origin:
            # As published: only FLSs within |q - p_h| + 2r of the source's origin.
            reach = np.sqrt((hx - qx) ** 2 + (hy - qy) ** 2 + (hz - qz) ** 2)
            reach += 2.0 * radius
            hits = _count_within(points, found[:hits], i, reach)
        if hits == 0:
            best, best_length = h, total
            if rules.first_helper:
                break
    return best


@jit.kernel(cache=True, nogil=True)
def _blocks_at(
    points: FloatArray, radius: float, qx: float, qy: float, qz: float, h: int, j: int
) -> bool:
    """Whether a body at q, cm, is in the way of h's view of j: the world's own test.

    The segment runs from h towards j, as the helper measures the target
    (``core.observe.readings_of``), and :func:`~swazure_ros.core.grid.blocks` judges it.
    """
    at = np.empty((1, 3))
    at[0, 0], at[0, 1], at[0, 2] = qx, qy, qz
    ax, ay, az = points[h, 0], points[h, 1], points[h, 2]
    dx, dy, dz = points[j, 0] - ax, points[j, 1] - ay, points[j, 2] - az
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length == 0.0:
        return False
    ux, uy, uz = dx / length, dy / length, dz / length
    return blocks(at, 0, ax, ay, az, ux, uy, uz, length, radius * radius)


@jit.kernel(cache=True, nogil=True)
def _count_within(points: FloatArray, members: IntArray, centre: int, reach: float) -> int:
    """How many of the points ``members`` lie within ``reach`` of point ``centre``, cm."""
    near = 0
    for k in members:
        ex = points[k, 0] - points[centre, 0]
        ey = points[k, 1] - points[centre, 1]
        ez = points[k, 2] - points[centre, 2]
        if np.sqrt(ex * ex + ey * ey + ez * ez) <= reach:
            near += 1
    return near


def _nearest_first(points: FloatArray, indptr: IntArray, indices: IntArray) -> IntArray:
    """Each CSR row's column indices by distance from the row's point, then by index."""
    rows = csr.run_of(indptr)
    distance = np.linalg.norm(points[indices] - points[rows], axis=1)
    return np.asarray(indices[np.lexsort((indices, distance, rows))], dtype=np.int64)


def move_source(
    evaluation: PlainPairs,
    threshold: int,
    compat: Compat = TEXT,
    first_probe: int = 0,
    source_body: bool = False,
) -> HeuristicResult:
    """Move Source (section 8) with probe steps delta = 1..``threshold`` on every BLOCKED pair.

    The source probes the 26 directions at ``delta * r`` for delta = 1 ..
    T and stops at the first probe from which a visible sweet neighbour of
    the target is a sweet neighbour in sight; a probe that collides drops
    its direction. The path is (source at the probe, helper, target).

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs.
    threshold : int
        T, from 1 to ``MAX_THRESHOLD`` (the published settings are 2 and 10).
    compat : Compat, default TEXT
    first_probe : int, default 0
        The pairs the run resolved before these (blocks before this one): a
        resolved pair's source at its probe is measured as FLS ``N +
        first_probe + k``, k its rank among these, which a noisy sensor's
        seeded draw depends on.
    source_body : bool, default False
        Take a helper only when the source's own body at the probe point
        leaves the helper's view of the target clear, as the swarm flies it
        (``--source-body``); the spec (section 8) does not check it.

    Returns
    -------
    HeuristicResult
        One move per resolved pair (the source to its probe, cm); ``flown``
        the distance flown from probe to probe, cm; the truth ``p_j - q``.

    Raises
    ------
    ValueError
        ``threshold`` outside 1 to ``MAX_THRESHOLD``.

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
    >>> from swazure_ros.core.heuristics.source import move_source
    >>> result = move_source(plain, threshold=2)
    >>> int(result.tried.sum()), int(result.resolved.sum())
    (600, 237)
    """
    if not 1 <= threshold <= MAX_THRESHOLD:
        raise ValueError(f"threshold must be 1 to {MAX_THRESHOLD} steps, got {threshold}")
    hood, pairs = evaluation.hood, evaluation.pairs
    swarm, sensor, grid = hood.swarm, hood.sensor, hood.grid
    size = len(pairs)
    found = PairFindings.nothing_yet(size)
    blocked = blocked_pairs(evaluation)
    found.tried[blocked] = True
    visible = hood.sweet_visible
    helpers = visible.indices.astype(np.int64)
    if compat.first_helper:
        helpers = _nearest_first(swarm.points, visible.indptr, helpers)
    reach = (threshold + 2) * swarm.radius if compat.collisions_near_origin else np.inf
    scene = ProbeScene(
        swarm.points,
        swarm.radius,
        sensor.sweet_min,
        sensor.sweet_max,
        visible.indptr,
        helpers,
    )
    helper, probe, flown_blocked = _probe_kernel(
        scene,
        grid,
        pairs.source[blocked],
        pairs.target[blocked],
        GRID_STEPS if compat.grid_steps else DIRECTIONS,
        int(threshold),
        probe_rules(compat, float(reach), source_body),
    )
    success = helper >= 0
    resolved_pairs = blocked[success]
    found.resolved[resolved_pairs] = True
    flown = np.zeros(size)
    flown[blocked] = flown_blocked
    # Hops q -> h -> j, measured with the source at its probe position q: the k-th resolved
    # pair of the run's as FLS N + k (the rows between, earlier blocks' probes, never read).
    moved_source = swarm.size + first_probe + np.arange(len(resolved_pairs))
    extended = np.empty((swarm.size + first_probe + len(resolved_pairs), 3))
    extended[: swarm.size] = swarm.points
    extended[moved_source] = probe[success]
    middle = helper[success]
    first_hop = measured_vectors(sensor, extended, swarm.radius, moved_source, middle)
    second_hop = measured_vectors(
        sensor, extended, swarm.radius, middle, pairs.target[resolved_pairs]
    )
    found.estimate[resolved_pairs] = first_hop + second_hop
    found.truth[resolved_pairs] = swarm.points[pairs.target[resolved_pairs]] - probe[success]
    rows = {
        int(pair): [int(pairs.source[pair]), int(h), int(pairs.target[pair])]
        for pair, h in zip(resolved_pairs, middle)
    }
    move_counts = np.zeros(size, dtype=np.int64)
    move_counts[resolved_pairs] = 1
    return HeuristicResult(
        technique=MOVE_SOURCE,
        threshold=threshold,
        tried=found.tried,
        resolved=found.resolved,
        estimate=found.estimate,
        truth=found.truth,
        paths=paths_from_rows(size, rows),
        move_offsets=csr.offsets(move_counts),
        move_fls=pairs.source[resolved_pairs].astype(np.int64),
        move_from=swarm.points[pairs.source[resolved_pairs]].reshape(-1, 3),
        move_to=probe[success].reshape(-1, 3),
        flown=flown,
        compat=compat,
        source_body=source_body,
    )


def source_body_in_the_way(result: HeuristicResult, swarm: Swarm) -> IntArray:
    """The resolved pairs of Move Source whose helper's view of the target the source's
    own body at its probe point blocks: those the swarm cannot fly as planned.

    The spec's rule (``source_body`` False) resolves them; the swarm's walk
    finds the helper blind to the target there (docs/protocol.md). With
    ``source_body`` True there are none.

    Parameters
    ----------
    result : HeuristicResult
        Move Source's, on ``swarm``.
    swarm : Swarm
        The swarm it ran on, every FLS at its point.

    Returns
    -------
    (K,) array of int
        Indices of those pairs, ascending.
    """
    in_the_way = [
        pair
        for pair in np.flatnonzero(result.resolved)
        for _, _, at in result.moves(int(pair))
        if _blocks_at(swarm.points, swarm.radius, *at, *result.paths.path(int(pair))[1:])
    ]
    return np.asarray(in_the_way, dtype=np.int64)
