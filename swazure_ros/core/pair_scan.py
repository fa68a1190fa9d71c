"""Pairs of points within reach of each other, scanned on a grid (compiled).

The search under :func:`.neighbours.neighbour_pairs` and
:func:`.neighbours.pair_counts`: each point reads the cells its reach touches
and keeps the later points within it, or only those no nearer than a least
distance, or only the pairs a mask or a price allows (:class:`Affordable`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import csr, jit
from .arrays import BoolArray, FloatArray, IntArray
from .grid import Grid, ball_cells


@dataclass(frozen=True)
class Affordable:
    """The pairs whose two FLSs together spare what the pair costs.

    Pair i-j, centre distance d (cm), is affordable when
    ``spare[i] + spare[j] >= per_cm * d + fixed``: a search's budget that
    its ends leave an edge (:class:`.local_paths` keeps only the edges its
    sources' paths may hop over, and never finds the others).
    """

    spare: FloatArray  # (N,), in the cost's units; -inf spares nothing
    per_cm: float  # cost per cm of centre distance
    fixed: float  # cost per pair


#: No pair is left out: every pair is affordable.
EVERY_PAIR = Affordable(np.empty(0), 0.0, 0.0)


@jit.kernel(cache=True, nogil=True)
def _within(
    points: FloatArray,
    node: int,
    reach: float,
    nearest: float,
    grid: Grid,
    out: IntArray,
    involving: BoolArray,
    spare: FloatArray,
    per_cm: float,
    fixed: float,
) -> int:
    """Points after ``node`` within ``reach`` of it and ``nearest`` or farther, into ``out``
    unless it is empty; how many.

    With ``involving`` (N,) (empty: every pair), only those of pairs that involve an FLS
    True there; with ``spare`` (N,) (empty: every pair), only the affordable pairs
    (:class:`Affordable`).
    """
    # Every pair of the node's is one to keep where no mask is given or the mask holds it.
    every = len(involving) == 0 or involving[node]
    priced = len(spare) > 0
    origin, cell, shape, cell_start, members = grid
    x, y, z = points[node, 0], points[node, 1], points[node, 2]
    limit, least = reach * reach, nearest * nearest
    lo0, lo1, lo2, hi0, hi1, hi2 = ball_cells(grid, x, y, z, reach)
    count = 0
    # Cells finer than the reach: those wholly beyond it are skipped (27 cells one reach
    # wide cover 6.4 times the ball's volume).
    for ix in range(lo0, hi0 + 1):
        gap_x = max(origin[0] + ix * cell - x, x - origin[0] - (ix + 1) * cell, 0.0)
        for iy in range(lo1, hi1 + 1):
            gap_y = max(origin[1] + iy * cell - y, y - origin[1] - (iy + 1) * cell, 0.0)
            if gap_x * gap_x + gap_y * gap_y > limit:
                continue
            for iz in range(lo2, hi2 + 1):
                gap_z = max(origin[2] + iz * cell - z, z - origin[2] - (iz + 1) * cell, 0.0)
                if gap_x * gap_x + gap_y * gap_y + gap_z * gap_z > limit:
                    continue
                key = (ix * shape[1] + iy) * shape[2] + iz
                for slot in range(cell_start[key], cell_start[key + 1]):
                    other = members[slot]
                    if other <= node or not (every or involving[other]):
                        continue
                    dx = points[other, 0] - x
                    dy = points[other, 1] - y
                    dz = points[other, 2] - z
                    squared = dx * dx + dy * dy + dz * dz
                    if least <= squared <= limit and (
                        not priced
                        or spare[node] + spare[other] >= per_cm * np.sqrt(squared) + fixed
                    ):
                        if len(out):
                            out[count] = other
                        count += 1
    return count


def pairs_within(
    points: FloatArray,
    reach: float,
    grid: Grid,
    start: int = 0,
    stop: int | None = None,
    involving: BoolArray | None = None,
    affordable: Affordable = EVERY_PAIR,
    nearest: float = 0.0,
) -> tuple[IntArray, IntArray]:
    """The pairs i < j of ``points`` within ``reach``, i in [start, stop), as CSR.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    reach : float, cm
        Centre distance, inclusive.
    grid : Grid
        The points' grid, cells of any size.
    start, stop : int, optional
        The block of first points (default: every point).
    involving : (N,) array of bool, optional
        Only the pairs of which i or j is True here (default: every pair).
    affordable : Affordable, optional
        Only the pairs it affords (default: every pair).
    nearest : float, optional
        Only the pairs at least this far apart, cm (default: every pair within
        ``reach``): those nearer are neither stored nor counted.

    Returns
    -------
    rows : (stop - start + 1,) array of int
        Row i - start's pairs are ``second[rows[i - start]:rows[i - start + 1]]``.
    second : (M,) array of int
        Each row's j, sorted.
    """
    scan = _scan(points, start, stop, involving, affordable)
    begin, end = scan[0], scan[1]
    # One pass, its output grown as it fills (a count first measured every pair twice), so
    # parts of the rows run on threads of their own; more parts than threads, to even them.
    threads = jit.get_num_threads()
    parts = max(1, min(4 * threads, (end - begin) // ROWS_PER_PART))

    def part(low: int, high: int) -> tuple[IntArray, IntArray]:
        counts, second = _rows(points, reach, nearest, grid, low, high, *scan[2:])
        return csr.offsets(counts), np.asarray(second)

    return csr.made_in_parts(part, begin, end, parts, threads, np.zeros(0, dtype=np.int64))


def counts_within(
    points: FloatArray, reach: float, grid: Grid, start: int = 0, stop: int | None = None
) -> IntArray:
    """How many later points lie within ``reach`` of each point, no pair stored.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    reach : float, cm
        Centre distance, inclusive.
    grid : Grid
        The points' grid, cells of any size.
    start, stop : int, optional
        The block of points counted for (default: every point).

    Returns
    -------
    (stop - start,) array of int
        Per point i, the j > i within reach.
    """
    scan = _scan(points, start, stop, None, EVERY_PAIR)
    return np.asarray(_counts(points, reach, grid, *scan))


def _scan(
    points: FloatArray,
    start: int,
    stop: int | None,
    involving: BoolArray | None,
    affordable: Affordable,
) -> tuple[int, int, BoolArray, FloatArray, float, float]:
    """The kernels' arguments after the grid: a block, a mask and a price (empty: none)."""
    stop = len(points) if stop is None else stop
    mask = np.empty(0, dtype=np.bool_) if involving is None else involving
    spare = np.ascontiguousarray(affordable.spare, dtype=np.float64)
    return start, stop, mask, spare, affordable.per_cm, affordable.fixed


@jit.kernel(cache=True, parallel=True)
def _counts(
    points: FloatArray,
    reach: float,
    grid: Grid,
    start: int,
    stop: int,
    involving: BoolArray,
    spare: FloatArray,
    per_cm: float,
    fixed: float,
) -> IntArray:
    """Per point of [start, stop), how many pairs :func:`_within` finds for it."""
    counts = np.zeros(stop - start, dtype=np.int64)
    nothing = np.empty(0, dtype=np.int64)
    for row in jit.prange(stop - start):
        node = start + row
        counts[row] = _within(
            points, node, reach, 0.0, grid, nothing, involving, spare, per_cm, fixed
        )
    return counts


#: Rows a part of :func:`pairs_within` scans at least: fewer are not worth a thread.
ROWS_PER_PART = 256


@jit.kernel(cache=True, nogil=True)
def _rows(
    points: FloatArray,
    reach: float,
    nearest: float,
    grid: Grid,
    start: int,
    stop: int,
    involving: BoolArray,
    spare: FloatArray,
    per_cm: float,
    fixed: float,
) -> tuple[IntArray, IntArray]:
    """The pairs :func:`_within` finds for each point of [start, stop), in one pass: each
    row's count, and the rows' j one after the other, each row's sorted."""
    counts = np.zeros(stop - start, dtype=np.int64)
    second = np.empty(1024, dtype=np.int64)
    filled = 0
    for row in range(stop - start):
        node = start + row
        room = len(points) - node - 1  # a row's pairs are with later points
        if filled + room > len(second):
            grown = np.empty(max(2 * len(second), filled + room), dtype=np.int64)
            grown[:filled] = second[:filled]
            second = grown
        out = second[filled : filled + room]
        count = _within(points, node, reach, nearest, grid, out, involving, spare, per_cm, fixed)
        out[:count].sort()
        counts[row] = count
        filled += count
    return counts, second[:filled]
