"""Point clouds: built-in shapes, validation and resampling.

Every shape is an ``(N, 3)`` float array in centimetres; :class:`CloudError`
says in one line why points cannot be used. Reading clouds from files is
:mod:`swazure_ros.files.cloud_files`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import jit
from .arrays import BoolArray, FloatArray, IntArray
from .errors import CloudError
from .grid import Grid, grid_of

#: Mean nearest-neighbour distance of the published shapes, cm (spec, section 10).
PUBLISHED_DENSITY = 0.65

#: Scale factors of the published point clouds, by file stem (spec, section 10).
PUBLISHED_SCALES: dict[str, float] = {
    "chess_408": 13.6,
    "palm_725": 34.0,
    "kangaroo_972": 34.0,
    "dragon_1147": 40.0,
    "skateboard_1372": 34.0,
    "racecar_3720": 40.0,
}

#: Resampling lists each point's close points once its spacing is bracketed this closely
#: (high / low, after three or four bisections): the twenty left each read those lists in
#: 0.04 s where a pass over the grid's cells took 0.3 s (the race car to 30,000 points).
LISTED_RATIO = 2.0

#: FLSs in one swarm, at most: 27 times the largest published shape (3,720).
MAX_POINTS = 100_000
#: cm from the origin that a point may lie, at most: a display is metres across, and
#: coordinates far beyond overflow the geometry's squares.
MAX_EXTENT = 1e6
#: Clouds of up to this many points have their spacing measured pair by pair
#: (:func:`mean_spacing`), without scipy.spatial: importing it costs a process about
#: 0.45 CPU-s and 35 MB, more than a small built-in shape's every pair, and every
#: process of one FLS makes its swarm's built-in shape (``--per-fls``).
PAIRWISE_SPACING_UP_TO = 4096
#: Points of a resampled cloud, at least: as of a built-in shape.
MIN_RESAMPLE = 8
#: Points a cloud needs to be resampled: each point and its six nearest neighbours.
RESAMPLE_NEIGHBOURS = 7


@dataclass(frozen=True)
class Resampled:
    """Where a resampled cloud came from: the cloud, and the resampling asked of it."""

    cloud: str  # the original's name
    cloud_source: str  # its file, or "builtin"
    scale: float  # its scale (to cm), before resampling
    points: int  # its points
    count: int  # the resampled cloud's points
    seed: int  # of resample()'s thinning and choice


@dataclass(frozen=True)
class Cloud:
    """A named point cloud in centimetres."""

    name: str
    points: FloatArray  # (N, 3), cm
    scale: float
    source: str  # file path or "builtin"
    resampled: Resampled | None = None  # what it was resampled from (--resample)


def validate_points(points: object, where: str = "points") -> FloatArray:
    """Coerce to an (N, 3) float array of finite values with N >= 2, or raise CloudError.

    At most :data:`MAX_POINTS` points, each within :data:`MAX_EXTENT` cm of the origin.
    The core's boundary for every cloud: a file's, a built-in shape's, or an array.

    Parameters
    ----------
    points : (N, 3) array_like of real numbers, cm
    where : str, default "points"
        What the points are, to start the error's message with (a file name).

    Returns
    -------
    (N, 3) array of float64, cm

    Raises
    ------
    CloudError
        Coordinates that are not real numbers, not 3 per point, NaN or
        infinite, fewer than 2 or more than :data:`MAX_POINTS` points, or a
        point beyond :data:`MAX_EXTENT`.

    Examples
    --------
    >>> from swazure_ros.core.clouds import validate_points
    >>> validate_points([[0, 0, 0], [1, 2, 3]])
    array([[0., 0., 0.],
           [1., 2., 3.]])
    >>> validate_points([[0, 0], [1, 1]], "cloud.xyz")
    Traceback (most recent call last):
    ...
    swazure_ros.core.errors.CloudError: cloud.xyz: expected 3 coordinates per point, ...(2, 2)
    """
    kind = getattr(points, "dtype", np.dtype(np.float64)).kind
    if kind not in "fiub":
        dtype = getattr(points, "dtype", None)
        raise CloudError(f"{where}: coordinates must be real numbers, got dtype {dtype}")
    try:
        array = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise CloudError(f"{where}: coordinates are not numbers ({err})") from err
    if array.ndim != 2 or array.shape[1] != 3:
        raise CloudError(
            f"{where}: expected 3 coordinates per point, got an array of shape {array.shape}"
        )
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise CloudError(f"{where}: point {row} has a NaN or infinite coordinate")
    if len(array) < 2:
        raise CloudError(f"{where}: a swarm needs at least two points, got {len(array)}")
    check_count(len(array), where)
    far = np.abs(array).max(axis=1) > MAX_EXTENT
    if far.any():
        row = int(np.flatnonzero(far)[0])
        raise CloudError(
            f"{where}: point {row} lies {np.abs(array[row]).max():.3g} cm out, beyond "
            f"{MAX_EXTENT:g} cm: is the scale right?"
        )
    return array


def check_count(count: int, where: str) -> None:
    """CloudError unless ``count`` FLSs are at most :data:`MAX_POINTS`; it says what more needs.

    Parameters
    ----------
    count : int
        FLSs in the swarm to be.
    where : str
        What they are, to start the error's message with.

    Raises
    ------
    CloudError
        ``count`` is over :data:`MAX_POINTS`; the message estimates the memory
        a swarm that size would need (about 10 kB per FLS).
    """
    if count > MAX_POINTS:
        # Neighbourhood, line of sight and paths hold ~10 kB per FLS at the published density.
        need = count * 10e3 / 2**30
        raise CloudError(
            f"{where}: {count} points, more than {MAX_POINTS} (a swarm that size would need "
            f"about {need:,.0f} GiB of memory)"
        )


def _at_density(points: FloatArray, density: float) -> FloatArray:
    """Rescale ``points`` so that their mean nearest-neighbour distance is ``density`` cm."""
    return points * (density / mean_spacing(points))


def mean_spacing(points: FloatArray) -> float:
    """Mean distance of each point to its nearest other point, cm.

    Up to ``PAIRWISE_SPACING_UP_TO`` points every pair is compared (numpy
    only), beyond that a k-d tree (scipy.spatial) finds the nearest; both
    give the same distances to the last bit (:func:`nearest_distances`).

    Parameters
    ----------
    points : (N, 3) array of float, cm
        N >= 2.

    Returns
    -------
    float, cm

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.clouds import mean_spacing
    >>> mean_spacing(np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0]]))  # (1 + 1 + 2) / 3
    1.3333333333333333
    """
    points = np.asarray(points, dtype=float)
    if len(points) <= PAIRWISE_SPACING_UP_TO:
        return float(nearest_distances(points).mean())
    from scipy.spatial import cKDTree  # here, not at import (PAIRWISE_SPACING_UP_TO)

    distances, _ = cKDTree(points).query(points, k=2)
    return float(distances[:, 1].mean())


def nearest_distances(points: FloatArray, rows: int = 256) -> FloatArray:
    """Each point's distance to its nearest other point, by comparing every pair, cm.

    The squares are summed x, then y, then z, from zero, and the root taken
    last: the order in which scipy.spatial's k-d tree sums them, so that the
    two give the same bits. ``rows`` points at a time: memory is ``rows`` x N.

    Parameters
    ----------
    points : (N, 3) array of float, cm
        N >= 2; a point that another repeats is 0 from it.
    rows : int, default 256
        Points compared with all others at once.

    Returns
    -------
    (N,) ndarray of float, cm
    """
    points = np.asarray(points, dtype=float)
    nearest = np.empty(len(points))
    for start in range(0, len(points), rows):
        block = points[start : start + rows]
        squares = np.zeros((len(block), len(points)))
        for axis in range(3):
            difference = block[:, None, axis] - points[None, :, axis]
            squares += difference * difference
        squares[np.arange(len(block)), np.arange(start, start + len(block))] = np.inf
        nearest[start : start + len(block)] = np.sqrt(squares.min(axis=1))
    return nearest


def resample(points: FloatArray, count: int, seed: int = 0) -> FloatArray:
    """``count`` points over the shape of ``points`` (N, 3), at its mean spacing: (count, 3), cm.

    A display-size version of a cloud: the shape grows so that its points
    keep their spacing. The shape is filled in by midpoints of each point's
    six nearest neighbours (chords of a surface stay near it) until it has
    four times ``count`` points, thinned in a seeded order to points at
    least a spacing apart (Poisson-disk sampling, the spacing bisected to
    the largest that keeps ``count``), ``count`` of those chosen, and the
    whole scaled to the mean spacing of ``points``. Deterministic per seed.

    Parameters
    ----------
    points : (N, 3) array_like of float, cm
        The shape; N >= 7 (each point's six nearest neighbours).
    count : int
        Points wanted, > 0; usually more than N.
    seed : int, default 0
        Seed of the thinning order and of the choice of the ``count`` points.

    Returns
    -------
    (count, 3) array of float, cm
        Its mean nearest-neighbour distance is that of ``points``.

    Raises
    ------
    CloudError
        ``count`` under :data:`MIN_RESAMPLE` or over :data:`MAX_POINTS`, or
        fewer than seven ``points``.

    Notes
    -----
    Ties are broken by order, so the result depends on ``seed`` alone:
    nearest neighbours at equal distances as scipy's cKDTree returns them;
    each chord once, the chords in ascending order of their two point
    indices; a point kept when no point earlier in the seeded order is
    closer than the spacing; the ``count`` points in their order in the
    dense cloud (the original points first, then each round's midpoints).

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points, mean_spacing, resample
    >>> grown = resample(builtin_points("sphere:200"), 500)
    >>> grown.shape, round(mean_spacing(grown), 2)
    ((500, 3), 0.65)
    """
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    original = np.asarray(points, dtype=np.float64)
    if not MIN_RESAMPLE <= count <= MAX_POINTS:
        raise CloudError(f"resample to {count} points: give {MIN_RESAMPLE} to {MAX_POINTS} points")
    if len(original) < RESAMPLE_NEIGHBOURS:
        raise CloudError(
            f"a cloud of {len(original)} points cannot be resampled: it needs "
            f"{RESAMPLE_NEIGHBOURS} (each point and its six nearest neighbours)"
        )
    dense = original
    while len(dense) < 4 * count:
        _, near = cKDTree(dense).query(dense, k=7)
        one, other = np.repeat(np.arange(len(dense)), 6), near[:, 1:].ravel()
        edges = np.unique(
            np.column_stack([np.minimum(one, other), np.maximum(one, other)]), axis=0
        )
        dense = np.concatenate([dense, (dense[edges[:, 0]] + dense[edges[:, 1]]) / 2.0])
    order = np.random.default_rng(seed).permutation(len(dense))
    low, high = 0.0, mean_spacing(original)
    kept = np.ones(len(dense), dtype=bool)
    earlier: _Earlier | None = None
    for _ in range(24):  # the spacing to 1 part in 10^7
        spacing = (low + high) / 2.0
        if earlier is None and high <= LISTED_RATIO * low:
            # Every later spacing is under this high: list each point's close points once.
            earlier = _earlier_within(dense, order, high)
        if earlier is None:
            thinned = _apart(dense, order, spacing, grid_of(dense, spacing))
        else:
            thinned = np.empty(len(dense), dtype=bool)
            thinned[order[::-1]] = _apart_listed(earlier.points, *earlier.pairs, spacing)
        if thinned.sum() >= count:
            low, kept = spacing, thinned
        else:
            high = spacing
    candidates = np.flatnonzero(kept)
    chosen = np.sort(np.random.default_rng(seed).choice(candidates, count, replace=False))
    grown: FloatArray = dense[chosen] * (mean_spacing(original) / mean_spacing(dense[chosen]))
    return grown


class _Earlier(NamedTuple):
    """Each point's points within a reach that come before it in a thinning order."""

    points: FloatArray  # (N, 3), cm: the points last in the order first
    pairs: tuple[IntArray, IntArray]  # CSR: row q's later rows, each a point earlier in order


def _earlier_within(points: FloatArray, order: IntArray, reach: float) -> _Earlier:
    """The points within ``reach`` (cm) of each point that come before it in ``order``.

    In the reversed order, the points before a point are the rows after its
    own: :func:`.pair_scan.pairs_within`'s pairs i < j.
    """
    from .pair_scan import pairs_within

    backwards = np.ascontiguousarray(points[order[::-1]])
    return _Earlier(backwards, pairs_within(backwards, reach, grid_of(backwards, reach)))


@jit.kernel(cache=True)
def _apart_listed(
    backwards: FloatArray, rows: IntArray, earlier: IntArray, spacing: float
) -> BoolArray:
    """:func:`_apart` over listed pairs (:class:`_Earlier`), for a spacing under their reach.

    The same mask, in the reversed order: a point is kept when none of the
    kept points listed before it is within ``spacing``, their distance
    judged as :func:`_apart` judges it (:func:`_closer`), so that ties fall alike.
    """
    kept = np.zeros(len(backwards), dtype=np.bool_)
    limit = spacing * spacing
    for node in range(len(backwards) - 1, -1, -1):
        clear = True
        for slot in range(rows[node], rows[node + 1]):
            other = earlier[slot]
            if kept[other] and _closer(backwards, other, node, limit):
                clear = False
                break
        kept[node] = clear
    return kept


@jit.kernel(cache=True, nogil=True)
def _closer(points: FloatArray, other: int, node: int, limit: float) -> bool:
    """Whether ``other`` lies nearer ``node`` than sqrt(``limit``): both thinnings' test."""
    dx = points[other, 0] - points[node, 0]
    dy = points[other, 1] - points[node, 1]
    dz = points[other, 2] - points[node, 2]
    return bool(dx * dx + dy * dy + dz * dz < limit)


@jit.kernel(cache=True)
def _apart(points: FloatArray, order: IntArray, spacing: float, grid: Grid) -> BoolArray:
    """Points kept in ``order`` when no point kept before is within ``spacing``: (N,) mask."""
    origin, cell, shape, cell_start, members = grid
    kept = np.zeros(len(points), dtype=np.bool_)
    limit = spacing * spacing
    for node in order:
        cx = min(int((points[node, 0] - origin[0]) / cell), shape[0] - 1)
        cy = min(int((points[node, 1] - origin[1]) / cell), shape[1] - 1)
        cz = min(int((points[node, 2] - origin[2]) / cell), shape[2] - 1)
        clear = True
        for ix in range(max(cx - 1, 0), min(cx + 2, shape[0])):
            for iy in range(max(cy - 1, 0), min(cy + 2, shape[1])):
                for iz in range(max(cz - 1, 0), min(cz + 2, shape[2])):
                    key = (ix * shape[1] + iy) * shape[2] + iz
                    for slot in range(cell_start[key], cell_start[key + 1]):
                        other = members[slot]
                        if kept[other] and _closer(points, other, node, limit):
                            clear = False
        kept[node] = clear
    return kept


def sphere_shell(count: int) -> FloatArray:
    """A Fibonacci lattice on a sphere of unit radius.

    Parameters
    ----------
    count : int
        Points, > 0.

    Returns
    -------
    (count, 3) array of float
        Unitless: :func:`builtin_points` scales it to cm.
    """
    index = np.arange(count) + 0.5
    polar = np.arccos(1.0 - 2.0 * index / count)
    azimuth = np.pi * (1.0 + 5.0**0.5) * index
    return np.column_stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    )


def torus(count: int, aspect: float = 3.0) -> FloatArray:
    """Points on a torus surface, tube radius 1 and ring radius ``aspect``.

    A staggered lattice: every other ring is turned by half a step.

    Parameters
    ----------
    count : int
        Points wanted, about; the lattice rounds it to rings times points per ring.
    aspect : float, default 3.0
        Ring radius over tube radius.

    Returns
    -------
    (M, 3) array of float
        M close to ``count`` (120 gives 120, 100 gives 102); unitless.
    """
    around_tube = max(3, round(math.sqrt(count / aspect)))
    around_ring = max(3, round(count / around_tube))
    ring, tube = np.meshgrid(
        np.linspace(0, 2 * np.pi, around_ring, endpoint=False),
        np.linspace(0, 2 * np.pi, around_tube, endpoint=False),
        indexing="ij",
    )
    # Shift every other ring by half a step: a staggered lattice, not a square one.
    tube = tube + (np.arange(around_ring)[:, None] % 2) * np.pi / around_tube
    radial = aspect + np.cos(tube)
    points = np.column_stack(
        [(radial * np.cos(ring)).ravel(), (radial * np.sin(ring)).ravel(), np.sin(tube).ravel()]
    )
    return points


def helix(count: int, turns: float = 4.0) -> FloatArray:
    """Points along a helix of unit radius and pitch 1 per turn, about the z axis.

    Parameters
    ----------
    count : int
        Points, >= 2, evenly spaced in angle from 0 to ``turns`` turns.
    turns : float, default 4.0

    Returns
    -------
    (count, 3) array of float
        Unitless.
    """
    angle = np.linspace(0, 2 * np.pi * turns, count)
    return np.column_stack([np.cos(angle), np.sin(angle), angle / (2 * np.pi)])


def cube_lattice(count: int) -> FloatArray:
    """A solid simple-cubic lattice of about ``count`` points with unit spacing.

    Parameters
    ----------
    count : int
        Points wanted, about: the side is its cube root, rounded, at least 2.

    Returns
    -------
    (M, 3) array of float
        M = side**3 (512 for 512, 27 for 30); unitless.
    """
    side = max(2, round(count ** (1 / 3)))
    axis = np.arange(side, dtype=np.float64)
    return np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)


#: Built-in shapes: name -> (generator, default count).
BUILTIN_SHAPES: dict[str, tuple[Callable[[int], FloatArray], int]] = {
    "sphere": (sphere_shell, 500),
    "sphere_shell": (sphere_shell, 500),  # the name display studies use for the same shell
    "torus": (torus, 400),
    "helix": (helix, 300),
    "cube": (cube_lattice, 512),
}

_BUILTIN_PATTERN = re.compile(r"^(?P<name>[a-z_]+)(?::(?P<count>\d+))?$")


def builtin_points(spec: str, density: float = PUBLISHED_DENSITY) -> FloatArray:
    """Points of a built-in shape ``NAME`` or ``NAME:COUNT``, at ``density`` cm mean spacing.

    Parameters
    ----------
    spec : str
        A name of :data:`BUILTIN_SHAPES` (sphere, sphere_shell, torus, helix,
        cube), with ``:COUNT`` for its points (default per shape).
    density : float, default PUBLISHED_DENSITY (0.65), cm
        The mean nearest-neighbour distance of the result: that of the
        published shapes.

    Returns
    -------
    (M, 3) array of float, cm
        M = COUNT for the sphere and helix, about COUNT for the torus and cube.

    Raises
    ------
    CloudError
        An unknown name (the message lists the names), fewer than 8 points,
        or more than :data:`MAX_POINTS`.

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points, mean_spacing
    >>> points = builtin_points("torus:120")
    >>> points.shape, round(mean_spacing(points), 2)
    ((120, 3), 0.65)
    """
    match = _BUILTIN_PATTERN.match(spec)
    if not match or match["name"] not in BUILTIN_SHAPES:
        names = ", ".join(sorted(BUILTIN_SHAPES))
        raise CloudError(f"unknown shape {spec!r}: use a file path or one of {names}")
    generator, default_count = BUILTIN_SHAPES[match["name"]]
    count = int(match["count"]) if match["count"] else default_count
    if count < 8:
        raise CloudError(f"shape {spec!r}: needs at least 8 points, got {count}")
    check_count(count, f"shape {spec!r}")
    return _at_density(generator(count), density)
