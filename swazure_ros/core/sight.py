"""Line of sight: which FLSs obstruct the segment between two others.

``obstructed(i, j)`` holds when some FLS ``k`` (not ``i``, not ``j``) has its
centre within distance ``r`` (inclusive) of the segment ``[p_i, p_j]``
(spec, section 4). Points are bucketed in a uniform grid (:mod:`.grid`);
each segment is walked in steps of one cell, scanning the cells of a box
around each step that holds every point within ``r`` of that stretch, each
cell once, and stopping at the first obstructer when only a yes or no is wanted.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray
from .grid import Grid, ball_cells, blocks, build_grid, scan_segment


@jit.kernel(cache=True, parallel=True)
def _close_points(
    points: FloatArray, grid: Grid, distance: float, nodes: IntArray
) -> tuple[IntArray, IntArray]:
    """The other points within ``distance`` of each of ``nodes`` (distinct), as CSR rows of
    every point: the others' rows are empty."""
    origin, cell, shape, cell_start, members = grid
    around = int(np.ceil(distance / cell))
    size = len(points)
    counts = np.zeros(size, dtype=np.int64)
    offsets = np.zeros(size + 1, dtype=np.int64)
    ids = np.empty(0, dtype=np.int64)
    limit = distance * distance
    for fill in (False, True):
        if fill:
            offsets[1:] = np.cumsum(counts)
            ids = np.empty(offsets[-1], dtype=np.int64)
        for at in jit.prange(len(nodes)):
            node = nodes[at]
            x, y, z = points[node, 0], points[node, 1], points[node, 2]
            c0 = min(int((x - origin[0]) / cell), shape[0] - 1)
            c1 = min(int((y - origin[1]) / cell), shape[1] - 1)
            c2 = min(int((z - origin[2]) / cell), shape[2] - 1)
            count = 0
            for i0 in range(max(c0 - around, 0), min(c0 + around + 1, shape[0])):
                for i1 in range(max(c1 - around, 0), min(c1 + around + 1, shape[1])):
                    for i2 in range(max(c2 - around, 0), min(c2 + around + 1, shape[2])):
                        key = (i0 * shape[1] + i1) * shape[2] + i2
                        for slot in range(cell_start[key], cell_start[key + 1]):
                            other = members[slot]
                            if other == node:
                                continue
                            dx = points[other, 0] - x
                            dy = points[other, 1] - y
                            dz = points[other, 2] - z
                            if dx * dx + dy * dy + dz * dz <= limit:
                                if fill:
                                    ids[offsets[node] + count] = other
                                count += 1
            counts[node] = count
    return offsets, ids


@jit.kernel(cache=True, nogil=True)
def any_within(
    points: FloatArray,
    x: float,
    y: float,
    z: float,
    distance: float,
    skip: int,
    grid: Grid,
    around: FloatArray,
    reach: float,
) -> bool:
    """Whether some point other than ``skip`` is strictly closer than ``distance`` to (x, y, z).

    A collision test for a probe position (compiled).

    Parameters
    ----------
    points : (N, 3) array of float, cm
    x, y, z : float, cm
        The position tested.
    distance : float, cm
        Closer than this (strictly) counts, e.g. 2r for a collision.
    skip : int
        An index that never counts (the FLS that moves there), or -1.
    grid : Grid
        The points' grid (:func:`~.grid.build_grid` or :func:`~.grid.grid_of`).
    around : (3,) array of float, cm
        Only points within ``reach`` of it count ...
    reach : float, cm
        ... or every point when ``reach`` is inf.

    Returns
    -------
    bool
    """
    _, _, shape, cell_start, members = grid
    lo0, lo1, lo2, hi0, hi1, hi2 = ball_cells(grid, x, y, z, distance)
    limit = distance * distance
    for c0 in range(lo0, hi0 + 1):
        for c1 in range(lo1, hi1 + 1):
            for c2 in range(lo2, hi2 + 1):
                key = (c0 * shape[1] + c1) * shape[2] + c2
                for slot in range(cell_start[key], cell_start[key + 1]):
                    k = members[slot]
                    if k == skip:
                        continue
                    ex, ey, ez = points[k, 0] - x, points[k, 1] - y, points[k, 2] - z
                    if ex * ex + ey * ey + ez * ez < limit:
                        if reach == np.inf:
                            return True
                        fx = points[k, 0] - around[0]
                        fy = points[k, 1] - around[1]
                        fz = points[k, 2] - around[2]
                        if np.sqrt(fx * fx + fy * fy + fz * fz) <= reach:
                            return True
    return False


def _obstructed_segments(
    points: FloatArray,
    radius: float,
    first: IntArray,
    second: IntArray,
    grid: Grid,
    close_offsets: IntArray,
    close_ids: IntArray,
) -> NDArray[np.bool_]:
    out = np.zeros(len(first), dtype=np.bool_)
    chunks = 64
    size = (len(first) + chunks - 1) // chunks
    radius2 = radius * radius
    for chunk in jit.prange(chunks):
        found = np.empty(1, dtype=np.int64)
        for pair in range(chunk * size, min((chunk + 1) * size, len(first))):
            a, b = first[pair], second[pair]
            ax, ay, az = points[a, 0], points[a, 1], points[a, 2]
            dx, dy, dz = points[b, 0] - ax, points[b, 1] - ay, points[b, 2] - az
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            hit = False
            if length > 0.0 and len(close_offsets) > 0:
                # The FLSs close to either end block most directions out of it: try
                # them first with the scan's own test, and scan only if none blocks.
                ux, uy, uz = dx / length, dy / length, dz / length
                for end in (a, b):
                    for slot in range(close_offsets[end], close_offsets[end + 1]):
                        k = close_ids[slot]
                        if k == a or k == b:  # noqa: SIM109 (numba: plain compares)
                            continue
                        if blocks(points, k, ax, ay, az, ux, uy, uz, length, radius2):
                            hit = True
                            break
                    if hit:
                        break
            if not hit:
                hit = scan_segment(points, radius, a, b, grid, found, True) > 0
            out[pair] = hit
    return out


#: :func:`obstructed` first tries the FLSs within this many r of a segment's ends.
CLOSE = 4.0

#: Below this many segments :func:`obstructed` judges them on the calling thread:
#: waking the parallel kernel's threads costs about a millisecond (measured), a
#: thousand segments' work. One source, compiled twice (prange runs as range).
SERIAL_SEGMENTS = 1024
_obstructed_kernel = jit.kernel(cache=True, parallel=True)(_obstructed_segments)
_obstructed_serial = jit.kernel(cache=True, nogil=True)(_obstructed_segments)


@jit.kernel(cache=True, nogil=True)
def _obstructers_kernel(
    points: FloatArray,
    radius: float,
    first: IntArray,
    second: IntArray,
    grid: Grid,
) -> tuple[IntArray, IntArray]:
    found = np.empty(len(points), dtype=np.int64)
    offsets = np.zeros(len(first) + 1, dtype=np.int64)
    capacity = max(16, 4 * len(first))
    ids = np.empty(capacity, dtype=np.int64)
    for pair in range(len(first)):
        hits = scan_segment(
            points,
            radius,
            first[pair],
            second[pair],
            grid,
            found,
            False,
        )
        start = offsets[pair]
        while start + hits > len(ids):
            grown = np.empty(2 * len(ids), dtype=np.int64)
            grown[: len(ids)] = ids
            ids = grown
        ids[start : start + hits] = np.sort(found[:hits])
        offsets[pair + 1] = start + hits
    return offsets, ids[: offsets[-1]].copy()


def coerce_pairs(
    points: ArrayLike, first: ArrayLike, second: ArrayLike
) -> tuple[FloatArray, IntArray, IntArray]:
    """Points and segment ends as the line-of-sight kernels take them, checked.

    Parameters
    ----------
    points : (N, 3) array_like, cm
    first, second : (M,) array_like of int
        Indices of the segment ends.

    Returns
    -------
    points : (N, 3) ndarray of float, C-contiguous
    first, second : (M,) ndarray of int64

    Raises
    ------
    ValueError
        ``points`` is not (N, 3), ``first`` and ``second`` differ in length,
        or an index is outside ``points``.
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3:
        raise ValueError(f"Expected `points` to have shape (N, 3), got {points.shape}")
    first = np.ascontiguousarray(first, dtype=np.int64).ravel()
    second = np.ascontiguousarray(second, dtype=np.int64).ravel()
    if first.shape != second.shape:
        raise ValueError(
            f"Expected `first` and `second` of one length, got {len(first)} and {len(second)}"
        )
    if len(first) and (
        min(first.min(), second.min()) < 0 or max(first.max(), second.max()) >= len(points)
    ):
        raise ValueError("`first` and `second` must index into `points`")
    return points, first, second


def obstructed(
    points: ArrayLike,
    radius: float,
    first: ArrayLike,
    second: ArrayLike,
    grid: Grid | None = None,
) -> NDArray[np.bool_]:
    """Whether each segment first[m]-second[m] is obstructed: (M,) bool.

    Line of sight (spec, section 4): an FLS other than the two ends
    obstructs when its centre is within r (inclusive) of the segment.
    Compiled, parallel over segments from :data:`SERIAL_SEGMENTS`; the FLSs
    within ``CLOSE`` r of either end are tried before the scan, since they
    settle most blocked segments.

    Parameters
    ----------
    points : (N, 3) array_like, cm
    radius : float, cm
        FLS radius r; an FLS obstructs when its centre is within r of a segment.
    first, second : (M,) array_like of int
        Indices of the segment ends.
    grid : Grid, optional
        A grid from :func:`~.grid.build_grid` for the same points and radius.

    Returns
    -------
    (M,) array of bool
        True where some FLS obstructs the segment.

    Raises
    ------
    ValueError
        ``points`` is not (N, 3), ``first`` and ``second`` differ in length,
        or an index is outside ``points``.

    Examples
    --------
    >>> from swazure_ros.core.sight import obstructed
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [5, 0.4, 0], [10, 0, 0], [5, 3, 0]])  # cm
    >>> obstructed(points, 0.5, [0, 0, 1], [2, 3, 3])  # FLS 1 is 0.4 cm off 0-2
    array([ True, False, False])
    """
    points, first, second = coerce_pairs(points, first, second)
    grid = grid if grid is not None else build_grid(points, radius)
    if len(first) == 0:
        return np.zeros(0, dtype=bool)
    if len(first) < SERIAL_SEGMENTS:  # too few segments to pay for lists of close FLSs
        # No lists at all, not empty ones: a path walk's one hop must not cost O(N).
        none = np.zeros(0, dtype=np.int64)
        return np.asarray(
            _obstructed_serial(points, float(radius), first, second, grid, none, none)
        )
    # An FLS at distance d from an end blocks the directions within asin(r / d) of its own.
    # Listed for the segments' ends only: a display's regions judge a few thousand FLSs'
    # segments each, and listing every FLS's took 44 ms a call at 65,536 FLSs.
    ends = np.zeros(len(points), dtype=np.bool_)
    ends[first], ends[second] = True, True
    offsets, ids = _close_points(points, grid, CLOSE * radius, np.flatnonzero(ends))
    return np.asarray(_obstructed_kernel(points, float(radius), first, second, grid, offsets, ids))


def obstructers(
    points: ArrayLike,
    radius: float,
    first: ArrayLike,
    second: ArrayLike,
    grid: Grid | None = None,
) -> tuple[IntArray, IntArray]:
    """Every obstructing FLS of each segment, as compressed sparse rows.

    The full lists (Move Obstructing moves each obstructer; the summary
    counts them), where :func:`obstructed` stops at the first.

    Parameters
    ----------
    points : (N, 3) array_like, cm
    radius : float, cm
        FLS radius r.
    first, second : (M,) array_like of int
        Indices of the segment ends.
    grid : Grid, optional
        A grid from :func:`~.grid.build_grid` for the same points and radius.

    Returns
    -------
    offsets : (M + 1,) array of int
    ids : array of int
        The obstructers of segment m are ``ids[offsets[m]:offsets[m + 1]]``,
        sorted.

    Raises
    ------
    ValueError
        As :func:`obstructed`.

    Examples
    --------
    >>> from swazure_ros.core.sight import obstructers
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [5, 0.4, 0], [10, 0, 0], [5, 3, 0]])  # cm
    >>> offsets, ids = obstructers(points, 0.5, [0, 0], [2, 3])
    >>> offsets.tolist(), ids.tolist()
    ([0, 1, 1], [1])
    """
    points, first, second = coerce_pairs(points, first, second)
    grid = grid if grid is not None else build_grid(points, radius)
    # The kernel grows its output as it goes, so parts run on threads of their own.
    threads = jit.get_num_threads()
    parts = max(1, min(threads, len(first) // SERIAL_SEGMENTS))

    def part(low: int, high: int) -> tuple[IntArray, IntArray]:
        offsets, ids = _obstructers_kernel(
            points, float(radius), first[low:high], second[low:high], grid
        )
        return np.asarray(offsets), np.asarray(ids)

    return csr.made_in_parts(part, 0, len(first), parts, threads, np.zeros(0, dtype=np.int64))


@jit.kernel(cache=True, parallel=True)
def _near_kernel(
    starts: FloatArray, ends: FloatArray, probes: FloatArray, reach: float
) -> NDArray[np.bool_]:
    near = np.zeros(len(starts), dtype=np.bool_)
    reach2 = reach * reach
    for m in jit.prange(len(starts)):
        a, b = starts[m], ends[m]
        d = b - a
        length2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        for k in range(len(probes)):
            q = probes[k]
            t = 0.0
            if length2 > 0:
                t = ((q[0] - a[0]) * d[0] + (q[1] - a[1]) * d[1] + (q[2] - a[2]) * d[2]) / length2
                t = min(1.0, max(0.0, t))
            x, y, z = a[0] + t * d[0] - q[0], a[1] + t * d[1] - q[1], a[2] + t * d[2] - q[2]
            if x * x + y * y + z * z <= reach2:
                near[m] = True
                break
    return near


def segments_near(
    points: ArrayLike, first: ArrayLike, second: ArrayLike, probes: ArrayLike, reach: float
) -> NDArray[np.bool_]:
    """Whether each segment first[m]-second[m] passes within ``reach`` of any probe.

    What a move can change: a segment whose line of sight must be judged
    again because an FLS left or reached a place near it.

    Parameters
    ----------
    points : (N, 3) array_like, cm
    first, second : (M,) array_like of int
        Indices of the segment ends.
    probes : (K, 3) array_like, cm
        Positions.
    reach : float, cm
        Within it (inclusive) counts.

    Returns
    -------
    (M,) array of bool

    Raises
    ------
    ValueError
        As :func:`obstructed`.

    Examples
    --------
    >>> from swazure_ros.core.sight import segments_near
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [5, 0.4, 0], [10, 0, 0], [5, 3, 0]])  # cm
    >>> segments_near(points, [0, 0], [2, 3], [[5, 2, 0]], 1.0)
    array([False,  True])
    """
    points, first, second = coerce_pairs(points, first, second)
    probes = np.ascontiguousarray(probes, dtype=np.float64).reshape(-1, 3)
    if len(first) == 0 or len(probes) == 0:
        return np.zeros(len(first), dtype=bool)
    return np.asarray(_near_kernel(points[first], points[second], probes, float(reach)))
