"""The uniform grid that every line-of-sight kernel takes, and the scan of a segment.

Points are bucketed in a dense uniform grid of cubic cells (:class:`Grid`,
:func:`build_grid`, :func:`grid_of`); :func:`scan_between` walks a segment
in steps of one cell, scanning the cells of a box around each step that
holds every point within ``r`` of that stretch, each cell once, and
:func:`blocks` is the one test of obstruction each scan makes
(:mod:`.sight` judges line of sight with them).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import csr, jit
from .arrays import FloatArray, IntArray

#: A position (x, y, z), cm, as a kernel takes it: three floats, no array.
Point = tuple[float, float, float]

#: Largest number of cells of the dense grid; coarser cells beyond it.
MAX_CELLS = 1 << 22


class Grid(NamedTuple):
    """Points bucketed into a dense uniform grid of cubic cells (a CSR over cells).

    A named tuple, so that every kernel takes the grid as one argument.
    """

    origin: FloatArray  # (3,), cm
    cell: float  # edge of a cell, cm
    shape: IntArray  # (3,), cells per axis
    cell_start: IntArray  # (cells + 1,), start of each cell in ``members``
    members: IntArray  # (N,), point indices sorted by cell


def build_grid(points: FloatArray, radius: float) -> Grid:
    """Bucket ``points`` into cells of about the point spacing, and at least r.

    Cells near the point spacing keep few points per cell and few cells per
    segment, whatever r is: the grid line of sight scans.

    Parameters
    ----------
    points : (N, 3) array of float, cm
        N >= 2.
    radius : float, cm
        The FLS radius r: the smallest cell edge.

    Returns
    -------
    Grid
        Cell edge: the median nearest-neighbour distance, or r if larger
        (coarser past :data:`MAX_CELLS` cells).
    """
    extent = np.ptp(points, axis=0)
    spacing, _ = nearest_neighbours(points)
    # Cells near the point spacing keep few points per cell and few cells per
    # segment, whatever r is.
    cell = max(float(np.median(spacing)), radius, float(extent.max()) * 1e-9, 1e-12)
    return grid_of(points, cell)


def nearest_neighbours(points: FloatArray) -> tuple[FloatArray, IntArray]:
    """Each point's nearest other point and the distance to it, with no k-d tree.

    The distance is rounded as scipy's ``cKDTree.query`` rounds it,
    sqrt((dx^2 + dy^2) + dz^2), so that :func:`build_grid`'s cell is the bits
    it was when a tree measured it; a tie goes to the lower index. A grid
    search in rings of cells, so that a run need not import scipy.spatial
    (BENCHMARKS.md "Speed targets"); with kernels run as Python
    (``NUMBA_DISABLE_JIT``), scipy's tree, whose ties may go either way.

    Parameters
    ----------
    points : (N, 3) array of float, cm
        N >= 2.

    Returns
    -------
    distance : (N,) array of float, cm
        0 where another point coincides.
    index : (N,) array of int
        The nearest other point.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.grid import nearest_neighbours
    >>> distance, index = nearest_neighbours(np.array([[0.0, 0, 0], [3, 0, 0], [3, 4, 0]]))
    >>> distance.tolist(), index.tolist()
    ([3.0, 3.0, 4.0], [1, 0, 1])
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    if jit.INTERPRET:
        # Kernels run as Python here (an FLS's own process): the ring search would
        # take seconds, the tree's query is compiled. The same distances.
        from scipy.spatial import cKDTree

        distances, indices = cKDTree(points).query(points, k=2)
        return distances[:, 1], np.asarray(indices[:, 1], dtype=np.int64)
    extent = float(np.ptp(points, axis=0).max())
    # About one point per cell for a surface of points (a display): a few rings each.
    grid = grid_of(points, extent / np.sqrt(len(points)))
    return _nearest_kernel(points, grid)


# Serial: a parallel kernel takes longer to load from the cache than this takes to run.
@jit.kernel(cache=True, nogil=True)
def _nearest_kernel(points: FloatArray, grid: Grid) -> tuple[FloatArray, IntArray]:
    origin, cell, shape, cell_start, members = grid
    count = len(points)
    distance = np.empty(count)
    index = np.empty(count, dtype=np.int64)
    widest = max(shape[0], max(shape[1], shape[2]))
    centre = np.empty(3, dtype=np.int64)
    for i in range(count):
        for axis in range(3):
            at = int(np.floor((points[i, axis] - origin[axis]) / cell))
            centre[axis] = min(max(at, 0), shape[axis] - 1)
        best, best_index, ring = np.inf, -1, 0
        while True:
            for ix in range(max(centre[0] - ring, 0), min(centre[0] + ring, shape[0] - 1) + 1):
                for iy in range(max(centre[1] - ring, 0), min(centre[1] + ring, shape[1] - 1) + 1):
                    for iz in range(
                        max(centre[2] - ring, 0), min(centre[2] + ring, shape[2] - 1) + 1
                    ):
                        away = max(
                            abs(ix - centre[0]), max(abs(iy - centre[1]), abs(iz - centre[2]))
                        )
                        if away != ring:
                            continue  # an inner ring's cell, searched already
                        key = (ix * shape[1] + iy) * shape[2] + iz
                        for slot in range(cell_start[key], cell_start[key + 1]):
                            j = members[slot]
                            if j == i:
                                continue
                            # cKDTree's rounding: a sum from 0 in axis order.
                            squared = 0.0
                            for axis in range(3):
                                step = points[i, axis] - points[j, axis]
                                squared += step * step
                            if squared < best or (squared == best and j < best_index):
                                best, best_index = squared, j
            # A point of a cell beyond this ring is more than (ring) cells away along one
            # axis; one cell of slack covers a point rounded into its neighbour cell.
            if ring >= widest or (best_index >= 0 and np.sqrt(best) <= (ring - 1) * cell):
                break
            ring += 1
        distance[i] = np.sqrt(best)
        index[i] = best_index
    return distance, index


def grid_of(points: FloatArray, cell: float) -> Grid:
    """Bucket ``points`` into cubic cells of at least ``cell`` cm (coarser if too many).

    Parameters
    ----------
    points : (N, 3) array of float, cm
    cell : float, cm
        The cell edge wanted; made 1.5 times coarser until the grid has at most
        :data:`MAX_CELLS` cells.

    Returns
    -------
    Grid
        Its origin is the points' lower corner; ``members`` lists the points
        cell by cell, each cell's in index order.

    Examples
    --------
    >>> from swazure_ros.core.grid import grid_of
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [5, 0.4, 0], [10, 0, 0], [5, 3, 0]])  # cm
    >>> grid = grid_of(points, 2.0)
    >>> grid.cell, grid.shape.tolist(), grid.members.tolist()
    (2.0, [6, 2, 1], [0, 1, 3, 2])
    """
    lower = points.min(axis=0)
    extent = np.ptp(points, axis=0)
    cell = max(cell, float(extent.max()) * 1e-9, 1e-12)
    while np.prod(np.floor(extent / cell) + 1) > MAX_CELLS:
        cell *= 1.5
    shape = (np.floor(extent / cell) + 1).astype(np.int64)
    coords = np.clip(np.floor((points - lower) / cell).astype(np.int64), 0, shape - 1)
    keys = (coords[:, 0] * shape[1] + coords[:, 1]) * shape[2] + coords[:, 2]
    members = np.argsort(keys, kind="stable").astype(np.int64)
    counts = np.bincount(keys, minlength=int(np.prod(shape)))
    cell_start = csr.offsets(counts)
    return Grid(lower, cell, shape, cell_start, members)


@jit.kernel(cache=True, nogil=True)
def ball_cells(grid: Grid, x: float, y: float, z: float, reach: float) -> tuple[int, ...]:
    """The box of cells that holds every point within ``reach`` of (x, y, z), clipped to the grid.

    Parameters
    ----------
    grid : Grid
    x, y, z : float, cm
        The ball's centre, any position.
    reach : float, cm
        The ball's radius.

    Returns
    -------
    tuple of int
        ``(lo0, lo1, lo2, hi0, hi1, hi2)``: the first and last cell on each
        axis, both included; empty on an axis where ``lo > hi`` (the ball
        misses the grid there).
    """
    origin, cell, shape, _, _ = grid
    return (
        max(int(np.floor((x - reach - origin[0]) / cell)), 0),
        max(int(np.floor((y - reach - origin[1]) / cell)), 0),
        max(int(np.floor((z - reach - origin[2]) / cell)), 0),
        min(int(np.floor((x + reach - origin[0]) / cell)), shape[0] - 1),
        min(int(np.floor((y + reach - origin[1]) / cell)), shape[1] - 1),
        min(int(np.floor((z + reach - origin[2]) / cell)), shape[2] - 1),
    )


@jit.kernel(cache=True, nogil=True)
def scan_ball(
    points: FloatArray, grid: Grid, x: float, y: float, z: float, reach: float, out: IntArray
) -> int:
    """Write the points within ``reach`` (inclusive) of (x, y, z) into ``out``; how many.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    grid : Grid
        The points' grid.
    x, y, z : float, cm
        The ball's centre, any position.
    reach : float, cm
        The ball's radius.
    out : (N,) array of int
        Filled from the start with the points found, cell by cell.

    Returns
    -------
    int
    """
    _, _, shape, cell_start, members = grid
    lo0, lo1, lo2, hi0, hi1, hi2 = ball_cells(grid, x, y, z, reach)
    limit = reach * reach
    count = 0
    for c0 in range(lo0, hi0 + 1):
        for c1 in range(lo1, hi1 + 1):
            for c2 in range(lo2, hi2 + 1):
                key = (c0 * shape[1] + c1) * shape[2] + c2
                for slot in range(cell_start[key], cell_start[key + 1]):
                    k = members[slot]
                    dx, dy, dz = points[k, 0] - x, points[k, 1] - y, points[k, 2] - z
                    if dx * dx + dy * dy + dz * dz <= limit:
                        out[count] = k
                        count += 1
    return count


@jit.kernel(cache=True, nogil=True)
def scan_segment(
    points: FloatArray,
    radius: float,
    a: int,
    b: int,
    grid: Grid,
    found: IntArray,
    stop_at_first: bool,
) -> int:
    """Write the obstructers of segment a-b into ``found``; return how many (compiled).

    Parameters
    ----------
    points : (N, 3) array of float, cm
    radius : float, cm
        The FLS radius r.
    a, b : int
        The segment's ends, FLS indices; they obstruct nothing.
    grid : Grid
        The points' grid (:func:`build_grid` or :func:`grid_of`).
    found : (N,) array of int
        Filled from the start with the obstructers found, in scan order.
    stop_at_first : bool
        Stop at the first obstructer (a yes/no judgement).

    Returns
    -------
    int
        Obstructers written; at most 1 with ``stop_at_first``.
    """
    start = (points[a, 0], points[a, 1], points[a, 2])
    end = (points[b, 0], points[b, 1], points[b, 2])
    return scan_between(points, radius, start, end, a, b, grid, found, stop_at_first)


@jit.kernel(cache=True, nogil=True)
def scan_between(
    points: FloatArray,
    radius: float,
    start: Point,
    end: Point,
    a: int,
    b: int,
    grid: Grid,
    found: IntArray,
    stop_at_first: bool,
) -> int:
    """Obstructers of the segment ``start``-``end``, skipping FLSs a and b (compiled).

    The segment is walked in steps of one cell; each step scans the cells of
    a box holding every point within r of that stretch, each cell once.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    radius : float, cm
        The FLS radius r; a point within r (inclusive) obstructs.
    start, end : tuple of 3 float, cm
        The segment's ends, (x, y, z): a probe position need not be an FLS's.
    a, b : int
        FLS indices that never obstruct (the segment's own FLSs; -1 for none).
    grid : Grid
        The points' grid (:func:`build_grid` or :func:`grid_of`).
    found : (N,) array of int
        Filled from the start with the obstructers found, in scan order.
    stop_at_first : bool
        Stop at the first obstructer.

    Returns
    -------
    int
        Obstructers written; 0 for a segment of length 0.
    """
    origin, cell, shape, cell_start, members = grid
    ax, ay, az = start
    bx, by, bz = end
    dx, dy, dz = bx - ax, by - ay, bz - az
    length = np.sqrt(dx * dx + dy * dy + dz * dz)
    if length == 0.0:
        return 0
    ux, uy, uz = dx / length, dy / length, dz / length
    # Samples every `cell` along the segment; a point within r of the segment
    # is within step/2 + r of some sample in every coordinate, so it lies in
    # that sample's box. Boxes move monotonically, so skipping the cells of
    # the previous box scans every cell exactly once.
    half = 0.5 * cell + radius
    samples = int(np.ceil(length / cell)) + 1
    radius2 = radius * radius
    count = 0
    plo0, plo1, plo2, phi0, phi1, phi2 = 1, 1, 1, 0, 0, 0  # empty previous box
    for sample in range(samples):
        along = min(sample * cell, length)
        x = ax + along * ux - origin[0]
        y = ay + along * uy - origin[1]
        z = az + along * uz - origin[2]
        lo0 = max(int(np.floor((x - half) / cell)), 0)
        lo1 = max(int(np.floor((y - half) / cell)), 0)
        lo2 = max(int(np.floor((z - half) / cell)), 0)
        hi0 = min(int(np.floor((x + half) / cell)), shape[0] - 1)
        hi1 = min(int(np.floor((y + half) / cell)), shape[1] - 1)
        hi2 = min(int(np.floor((z + half) / cell)), shape[2] - 1)
        for ix in range(lo0, hi0 + 1):
            inside0 = plo0 <= ix <= phi0
            for iy in range(lo1, hi1 + 1):
                inside1 = inside0 and plo1 <= iy <= phi1
                for iz in range(lo2, hi2 + 1):
                    if inside1 and plo2 <= iz <= phi2:
                        continue
                    key = (ix * shape[1] + iy) * shape[2] + iz
                    for slot in range(cell_start[key], cell_start[key + 1]):
                        k = members[slot]
                        if k == a or k == b:  # noqa: SIM109 (numba: plain compares)
                            continue
                        if blocks(points, k, ax, ay, az, ux, uy, uz, length, radius2):
                            found[count] = k
                            count += 1
                            if stop_at_first:
                                return count
        plo0, plo1, plo2, phi0, phi1, phi2 = lo0, lo1, lo2, hi0, hi1, hi2
    return count


@jit.kernel(cache=True, nogil=True)
def blocks(
    points: FloatArray,
    k: int,
    ax: float,
    ay: float,
    az: float,
    ux: float,
    uy: float,
    uz: float,
    length: float,
    radius2: float,
) -> bool:
    """Whether point k is within r of the segment from a along unit u (compiled).

    The one test of obstruction every scan uses, so that a shortcut that
    tries a point with it finds what the scan would.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    k : int
        The point tried.
    ax, ay, az : float, cm
        The segment's start.
    ux, uy, uz : float
        Its unit direction.
    length : float, cm
        Its length.
    radius2 : float, cm^2
        r squared.

    Returns
    -------
    bool
        True when the point's distance to the segment is at most r.
    """
    wx, wy, wz = points[k, 0] - ax, points[k, 1] - ay, points[k, 2] - az
    projection = wx * ux + wy * uy + wz * uz
    projection = min(max(projection, 0.0), length)
    ox = wx - projection * ux
    oy = wy - projection * uy
    oz = wz - projection * uz
    return bool(ox * ox + oy * oy + oz * oz <= radius2)
