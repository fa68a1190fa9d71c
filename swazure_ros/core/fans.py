"""Line of sight from one FLS to many at once: its surroundings mapped by direction.

:func:`~.sight.obstructed` scans each segment on its own through the grid,
a cell at a time: 5.6 us for a decaying pair in sight on a display-size
race car, whose 55 million decaying pairs take most of its run (BENCHMARKS.md,
"Where a resampled race car's time and memory go"). The segments from one FLS
A share their start, and what can block them. :func:`obstructed_fans` judges
the segments of each A together:

1. the FLSs within reach of A (the longest segment and r) are sorted by
   their distance from A into shells;
2. those within ``NEAR`` r of A (which block the most directions) are kept
   in a list; each other FLS K, at distance d, can block only the directions
   within asin(r / d) of its own, and is entered in every cell of a coarse
   grid over the unit vectors that such a direction may fall in;
3. a segment A-B is tried against the near list, then against the FLSs of
   its direction's cell, nearest shells first, up to its length and r.

Each FLS tried is judged by :func:`~.grid.blocks`, the one test every scan
uses, and every FLS that could block a segment is tried, so each judgement is
:func:`~.sight.obstructed`'s (docs/core.md, "Why it is fast").
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import jit
from .arrays import FloatArray, IntArray
from .grid import Grid, blocks, grid_of, scan_ball
from .sight import coerce_pairs, obstructed

#: The FLSs within this many r of the shared end are tried first, against every segment.
NEAR = 4.0
#: Edge of a cell of the grid over unit vectors (chord length): measured best of
#: 0.08 to 0.25 on the race car resampled to 15,000 FLSs.
DIRECTION_CELL = 0.2
#: Shells of distance from the shared end that the FLSs around it are sorted into.
SHELLS = 64
#: A shared end with fewer segments than this has them judged by the scan: mapping its
#: surroundings costs about as much as the scan's 250 segments (measured on the race
#: car resampled to 30,000 FLSs: 190 us a map, 1 us a segment scanned).
FEWEST_FANNED = 256


class _Scratch(NamedTuple):
    """One thread's working arrays, grown as needed and kept from one shared end to the next."""

    around: IntArray  # (N,), the FLSs within reach of A ...
    distance: FloatArray  # (N,), ... their distances from A, cm
    shell: IntArray  # (N,), ... and shells
    order: IntArray  # (N,), positions into ``around``, by shell
    shell_start: IntArray  # (SHELLS + 1,)
    cell_end: IntArray  # (cells,), end of each direction cell's entries; 0 when empty
    cell_start: IntArray  # (cells,)
    touched: IntArray  # (cells,), the cells with entries
    entry_cell: IntArray  # entries: a direction cell ...
    entry_fls: IntArray  # ... an FLS that may block in it ...
    entry_distance: FloatArray  # ... and its distance from A
    cell_fls: IntArray  # the entries by cell, nearest shells first
    cell_distance: FloatArray


def obstructed_fans(
    points: ArrayLike,
    radius: float,
    first: ArrayLike,
    second: ArrayLike,
    fewest: int = FEWEST_FANNED,
    grid: Grid | None = None,
) -> NDArray[np.bool_]:
    """Whether each segment first[m]-second[m] is obstructed, judged a shared first end at a time.

    The same judgements as :func:`~.sight.obstructed`, made faster where each
    FLS starts thousands of long segments and few are blocked close to it (a
    display's decaying pairs: BENCHMARKS.md, "Line of sight by fans"). The
    segments of a first end that starts fewer than ``fewest`` are scanned.

    Parameters
    ----------
    points : (N, 3) array_like, cm
    radius : float, cm
        FLS radius r; an FLS obstructs when its centre is within r of a segment.
    first, second : (M,) array_like of int
        Indices of the segment ends, sorted by ``first`` (as neighbour pairs come).
    fewest : int, optional
        The fewest segments a first end's fan is worth mapping for
        (:data:`FEWEST_FANNED`); 1 fans every end.
    grid : Grid, optional
        ``grid.build_grid(points, radius)``, for the segments scanned: a caller
        that judges many small sets keeps it (each would build it again: a
        display's region by region, over half their time).

    Returns
    -------
    (M,) array of bool
        True where some FLS other than the ends obstructs the segment.

    Raises
    ------
    ValueError
        ``points`` is not (N, 3), ``first`` and ``second`` differ in length,
        an index is outside ``points``, or ``first`` is not sorted.

    Examples
    --------
    >>> from swazure_ros.core.fans import obstructed_fans
    >>> import numpy as np
    >>> points = np.array([[0.0, 0, 0], [5, 0.4, 0], [10, 0, 0], [5, 3, 0]])  # cm
    >>> obstructed_fans(points, 0.5, [0, 0, 1], [2, 3, 3])  # FLS 1 is 0.4 cm off 0-2
    array([ True, False, False])
    """
    points, first, second = coerce_pairs(points, first, second)
    if len(first) == 0:
        return np.zeros(0, dtype=bool)
    if np.any(first[1:] < first[:-1]):
        raise ValueError("`first` must be sorted: segments come grouped by their first end")
    bounds = np.flatnonzero(np.diff(first)) + 1
    starts = np.concatenate(([0], bounds, [len(first)])).astype(np.int64)
    fanned = np.repeat(np.diff(starts) >= fewest, np.diff(starts))
    if not fanned.all():
        out = np.zeros(len(first), dtype=np.bool_)
        scanned = ~fanned
        out[scanned] = obstructed(points, radius, first[scanned], second[scanned], grid)
        if fanned.any():
            out[fanned] = obstructed_fans(points, radius, first[fanned], second[fanned], 1)
        return out
    reach = _longest(points, first, second) + radius
    # Cells of a quarter of the reach: the ball round A spans about 9 on an axis.
    around = grid_of(points, max(reach / 4.0, radius))
    out = np.zeros(len(first), dtype=np.bool_)
    chunks = min(len(starts) - 1, 16 * jit.get_num_threads())
    _fans_kernel(points, float(radius), first[starts[:-1]], starts, second, around, chunks, out)
    return out


@jit.kernel(cache=True, nogil=True)
def _longest(points: FloatArray, first: IntArray, second: IntArray) -> float:
    longest = 0.0
    for pair in range(len(first)):
        a, b = first[pair], second[pair]
        dx, dy, dz = (points[b, 0] - points[a, 0], points[b, 1] - points[a, 1],
                      points[b, 2] - points[a, 2])  # fmt: skip
        longest = max(longest, np.sqrt(dx * dx + dy * dy + dz * dz))
    return longest


@jit.kernel(cache=True, nogil=True)
def _direction_cells() -> int:
    """Cells on an axis of the grid over unit vectors, [-1, 1] in cells of DIRECTION_CELL."""
    return int(np.ceil(2.0 / DIRECTION_CELL)) + 1


@jit.kernel(cache=True, nogil=True)
def _direction_index(coordinate: float, cells: int) -> int:
    """The cell of a unit vector's coordinate (or of a bound of a box of them), clipped."""
    return min(max(int(np.floor((coordinate + 1.0) / DIRECTION_CELL)), 0), cells - 1)


@jit.kernel(cache=True, parallel=True)
def _fans_kernel(
    points: FloatArray,
    radius: float,
    shared: IntArray,
    starts: IntArray,
    second: IntArray,
    around: Grid,
    chunks: int,
    out: NDArray[np.bool_],
) -> None:
    """Judge the segments of each run [starts[g], starts[g + 1]), all from FLS shared[g]."""
    cells = _direction_cells() ** 3
    size = len(points)
    for chunk in jit.prange(chunks):
        scratch = _Scratch(
            np.empty(size, dtype=np.int64),
            np.empty(size),
            np.empty(size, dtype=np.int64),
            np.empty(size, dtype=np.int64),
            np.zeros(SHELLS + 1, dtype=np.int64),
            np.zeros(cells, dtype=np.int64),
            np.zeros(cells, dtype=np.int64),
            np.empty(cells, dtype=np.int64),
            np.empty(1024, dtype=np.int64),
            np.empty(1024, dtype=np.int64),
            np.empty(1024),
            np.empty(1024, dtype=np.int64),
            np.empty(1024),
        )
        for run in range(chunk, len(shared), chunks):
            start, stop = starts[run], starts[run + 1]
            scratch = _fan(
                points, radius, shared[run], second[start:stop], around, scratch,
                out[start:stop],
            )  # fmt: skip


@jit.kernel(cache=True, nogil=True)
def _grown(array: NDArray[Any], used: int) -> NDArray[Any]:
    """A copy of ``array`` (ints or reals) twice as long, of which the first ``used`` are set."""
    grown = np.empty(2 * len(array), dtype=array.dtype)
    grown[:used] = array[:used]
    return grown


@jit.kernel(cache=True, nogil=True)
def _fan(
    points: FloatArray,
    radius: float,
    a: int,
    ends: IntArray,
    around: Grid,
    scratch: _Scratch,
    out: NDArray[np.bool_],
) -> _Scratch:
    """Judge the segments from FLS ``a`` to each of ``ends`` into ``out``; the scratch, grown."""
    count, reach = _gather(points, radius, a, ends, around, scratch)
    scratch = _by_shell(scratch, count)
    near = NEAR * radius
    scratch, touched = _map_directions(points, radius, a, scratch, count, near)
    shell_width = reach / SHELLS
    radius2 = radius * radius
    cells = _direction_cells()
    ax, ay, az = points[a, 0], points[a, 1], points[a, 2]
    for index in range(len(ends)):
        b = ends[index]
        # The segment's direction and length as the scan works them out (grid.scan_segment).
        dx, dy, dz = points[b, 0] - ax, points[b, 1] - ay, points[b, 2] - az
        length = np.sqrt(dx * dx + dy * dy + dz * dz)
        if length == 0.0:
            out[index] = False
            continue
        ux, uy, uz = dx / length, dy / length, dz / length
        hit = False
        for position in range(count):  # the near FLSs, nearest shells first
            k = scratch.order[position]
            if scratch.distance[k] > near:
                if scratch.distance[k] > near + shell_width:
                    break  # shells beyond the near ones
                continue
            fls = scratch.around[k]
            if fls != b and blocks(points, fls, ax, ay, az, ux, uy, uz, length, radius2):
                hit = True
                break
        if not hit:
            cell = (
                _direction_index(ux, cells) * cells + _direction_index(uy, cells)
            ) * cells + _direction_index(uz, cells)
            # An FLS beyond the segment's length and r cannot come within r of it.
            limit = (length + radius) * (1.0 + 1e-9)
            for entry in range(scratch.cell_start[cell], scratch.cell_end[cell]):
                distance = scratch.cell_distance[entry]
                if distance > limit:
                    if distance > limit + shell_width:
                        break  # the entries come nearest shells first
                    continue
                fls = scratch.cell_fls[entry]
                if fls != b and blocks(points, fls, ax, ay, az, ux, uy, uz, length, radius2):
                    hit = True
                    break
        out[index] = hit
    for position in range(touched):
        cell = scratch.touched[position]
        scratch.cell_start[cell] = scratch.cell_end[cell] = 0
    return scratch


@jit.kernel(cache=True, nogil=True)
def _gather(
    points: FloatArray,
    radius: float,
    a: int,
    ends: IntArray,
    around: Grid,
    scratch: _Scratch,
) -> tuple[int, float]:
    """The FLSs within reach of ``a`` (its longest segment and r) into ``scratch``, with their
    distances and shells (its arrays hold N); how many, and the reach."""
    ax, ay, az = points[a, 0], points[a, 1], points[a, 2]
    longest = 0.0
    for b in ends:
        dx, dy, dz = points[b, 0] - ax, points[b, 1] - ay, points[b, 2] - az
        longest = max(longest, np.sqrt(dx * dx + dy * dy + dz * dz))
    # A margin far above rounding: an FLS within r of a segment is within its length and r.
    reach = (longest + radius) * (1.0 + 1e-9) + 1e-9
    shell_width = reach / SHELLS
    # Compacted in place: the FLSs found, less A, each with its distance and shell.
    found = scan_ball(points, around, ax, ay, az, reach, scratch.around)
    count = 0
    for position in range(found):
        k = scratch.around[position]
        if k == a:
            continue
        wx, wy, wz = points[k, 0] - ax, points[k, 1] - ay, points[k, 2] - az
        distance = np.sqrt(wx * wx + wy * wy + wz * wz)
        scratch.around[count], scratch.distance[count] = k, distance
        scratch.shell[count] = min(int(distance / shell_width), SHELLS - 1)
        count += 1
    return count, reach


@jit.kernel(cache=True, nogil=True)
def _by_shell(scratch: _Scratch, count: int) -> _Scratch:
    """``scratch.order``: the first ``count`` FLSs around, by shell (a counting sort)."""
    start = scratch.shell_start
    start[:] = 0
    for k in range(count):
        start[scratch.shell[k] + 1] += 1
    for shell in range(SHELLS):
        start[shell + 1] += start[shell]
    for k in range(count):
        shell = scratch.shell[k]
        scratch.order[start[shell]] = k
        start[shell] += 1
    return scratch


@jit.kernel(cache=True, nogil=True)
def _map_directions(
    points: FloatArray, radius: float, a: int, scratch: _Scratch, count: int, near: float
) -> tuple[_Scratch, int]:
    """Enter each FLS around ``a`` beyond ``near`` in the direction cells it may block, by
    shell; the scratch (``cell_start``, ``cell_end``, its entries) and the cells touched."""
    cells = _direction_cells()
    entry_cell, entry_fls, entry_distance = (
        scratch.entry_cell,
        scratch.entry_fls,
        scratch.entry_distance,
    )
    ax, ay, az = points[a, 0], points[a, 1], points[a, 2]
    used = 0
    for position in range(count):
        k = scratch.order[position]
        distance = scratch.distance[k]
        if distance <= near:
            continue
        fls = scratch.around[k]
        # A direction it blocks is within asin(r / d) of its own, a chord at most that long;
        # tan(asin(x)) = x / sqrt(1 - x^2) bounds it from above, with a margin above rounding.
        sine = radius / distance
        spread = sine / np.sqrt(1.0 - sine * sine) * (1.0 + 1e-6) + 1e-9
        ux = (points[fls, 0] - ax) / distance
        uy = (points[fls, 1] - ay) / distance
        uz = (points[fls, 2] - az) / distance
        for i0 in range(
            _direction_index(ux - spread, cells), _direction_index(ux + spread, cells) + 1
        ):
            for i1 in range(
                _direction_index(uy - spread, cells), _direction_index(uy + spread, cells) + 1
            ):
                for i2 in range(
                    _direction_index(uz - spread, cells), _direction_index(uz + spread, cells) + 1
                ):
                    if used == len(entry_cell):
                        entry_cell = _grown(entry_cell, used)
                        entry_fls = _grown(entry_fls, used)
                        entry_distance = _grown(entry_distance, used)
                    entry_cell[used] = (i0 * cells + i1) * cells + i2
                    entry_fls[used], entry_distance[used] = fls, distance
                    used += 1
    # The entries by cell (a stable counting sort, so each cell's stay nearest shells first).
    cell_start, cell_end, touched = scratch.cell_start, scratch.cell_end, scratch.touched
    count_touched = 0
    for entry in range(used):
        cell = entry_cell[entry]
        if cell_end[cell] == 0:
            touched[count_touched] = cell
            count_touched += 1
        cell_end[cell] += 1
    place = 0
    for position in range(count_touched):
        cell = touched[position]
        cell_start[cell], place = place, place + cell_end[cell]
        cell_end[cell] = cell_start[cell]
    cell_fls, cell_distance = scratch.cell_fls, scratch.cell_distance
    if len(cell_fls) < used:
        cell_fls, cell_distance = np.empty(len(entry_cell), np.int64), np.empty(len(entry_cell))
    for entry in range(used):
        cell = entry_cell[entry]
        cell_fls[cell_end[cell]], cell_distance[cell_end[cell]] = (
            entry_fls[entry],
            entry_distance[entry],
        )
        cell_end[cell] += 1
    grown = _Scratch(
        *scratch[:8], entry_cell, entry_fls, entry_distance, cell_fls, cell_distance,
    )  # fmt: skip
    return grown, count_touched
