"""Geometry of a swarm: dmin, FLS radius, collision removal, distances.

Every FLS is a sphere of radius ``r`` around its point; ``r = beta * dmin``.
Distances between two centres are computed by :func:`centre_distance` and
nowhere else, so that a pair at exactly ``2r`` has a tracking distance of
exactly 0 wherever it is computed.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from . import jit
from .arrays import FloatArray, IntArray
from .clouds import validate_points
from .errors import CloudError
from .grid import nearest_neighbours

#: Two FLSs touch (a kissing pair) when their tracking distance is within this, cm.
KISSING_TOLERANCE = 1e-3


@dataclass(frozen=True)
class Swarm:
    """FLS centres (cm) and radius after collision removal."""

    points: FloatArray  # (N, 3), cm
    radius: float  # r, cm
    dmin: float  # smallest centre distance of the original cloud, cm
    beta: float | None  # r / dmin when the radius came from beta
    cloud_index: IntArray  # (N,), index of each FLS in the original cloud
    removed: int  # FLSs removed because they collided

    @property
    def size(self) -> int:
        """Number of FLSs."""
        return len(self.points)


#: Pairs from which :func:`centre_distance` runs compiled on every core: numpy's
#: gathers take 0.7 s for the race car's 6.8 M candidate neighbour pairs.
COMPILED_PAIRS = 1 << 20


def centre_distance(points: FloatArray, first: ArrayLike, second: ArrayLike) -> FloatArray:
    """Centre-to-centre distances |p_second - p_first|, cm, for index arrays of one shape.

    The one place a centre distance is computed, so that a pair at exactly
    ``2r`` has a tracking distance of exactly 0 wherever it is used. From
    :data:`COMPILED_PAIRS` pairs it runs compiled on every core, summing in
    the same order as numpy, so both give the same bits.

    Parameters
    ----------
    points : (N, 3) array_like of float, cm
        FLS centres.
    first, second : array_like of int
        Indices into ``points``, of one shape (any shape, e.g. (M,)).

    Returns
    -------
    array of float, cm
        The distances, of the shape of ``first``.

    Examples
    --------
    >>> from swazure_ros.core.geometry import centre_distance
    >>> points = [[0, 0, 0], [3, 4, 0], [0, 0, 2]]
    >>> centre_distance(points, [0, 0], [1, 2])
    array([5., 2.])
    """
    points = np.asarray(points, dtype=np.float64)
    first, second = np.asarray(first), np.asarray(second)
    if first.ndim == 1 and first.shape == second.shape and len(first) >= COMPILED_PAIRS:
        first, second = first.astype(np.int64, copy=False), second.astype(np.int64, copy=False)
        return _centre_distance(np.ascontiguousarray(points), first, second)
    offset = points[second] - points[first]
    dx, dy, dz = offset[..., 0], offset[..., 1], offset[..., 2]
    # Summed as (x² + z²) + y²: the order numpy's einsum took where every published
    # result of this project was recorded; written out, it is the same on any CPU.
    return np.asarray(np.sqrt((dx * dx + dz * dz) + dy * dy), dtype=np.float64)


@jit.kernel(cache=True, parallel=True)
def _centre_distance(points: FloatArray, first: IntArray, second: IntArray) -> FloatArray:
    # numpy's operations in numpy's order, so that both give the same bits.
    distance = np.empty(len(first))
    for m in jit.prange(len(first)):
        dx = points[second[m], 0] - points[first[m], 0]
        dy = points[second[m], 1] - points[first[m], 1]
        dz = points[second[m], 2] - points[first[m], 2]
        distance[m] = np.sqrt((dx * dx + dz * dz) + dy * dy)
    return distance


def tracking_distance(
    points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> FloatArray:
    """Surface-to-surface (tracking) distances |p_second - p_first| - 2r, cm.

    What the camera on one FLS's surface measures to the marker on the
    other's; every range decision uses it (spec, section 2).

    Parameters
    ----------
    points : (N, 3) array_like of float, cm
        FLS centres.
    radius : float, cm
        The FLS radius r.
    first, second : array_like of int
        Indices into ``points``, of one shape.

    Returns
    -------
    array of float, cm
        The tracking distances, of the shape of ``first``; negative for
        spheres that overlap.

    Examples
    --------
    >>> from swazure_ros.core.geometry import tracking_distance
    >>> tracking_distance([[0, 0, 0], [10, 0, 0]], 1.0, [0], [1])
    array([8.])
    """
    return centre_distance(points, first, second) - 2.0 * radius


#: Clouds up to this many points are searched pair by pair, without a k-d tree: an FLS
#: in its own process builds its shape's points this way without importing scipy
#: (30 MB of a process); the two searches give the same pairs and distances.
SMALL_CLOUD = 2048
#: Rows of the pairwise search at a time (a few MB of differences).
_ROWS = 128


def _pair_blocks(count: int) -> Iterator[tuple[IntArray, IntArray]]:
    """Every unordered pair of ``count`` points, first < second, a block of rows at a time."""
    for start in range(0, count, _ROWS):
        rows = np.arange(start, min(start + _ROWS, count))
        others = np.arange(start + 1, count)
        first, second = np.repeat(rows, len(others)), np.tile(others, len(rows))
        keep = first < second
        yield first[keep], second[keep]


def min_distance(points: ArrayLike) -> float:
    """dmin: the smallest centre-to-centre distance between two points, cm.

    Clouds up to :data:`SMALL_CLOUD` points are searched pair by pair (no
    kernel to compile), larger ones on a grid (:func:`.grid.nearest_neighbours`);
    both give the same distance.

    Parameters
    ----------
    points : (N, 3) array_like of float, cm
        At least two finite points.

    Returns
    -------
    float, cm
        The smallest distance; 0 when two points coincide.

    Raises
    ------
    CloudError
        ``points`` is not an (N, 3) array of finite numbers with N >= 2.

    Examples
    --------
    >>> from swazure_ros.core.geometry import min_distance
    >>> min_distance([[0, 0, 0], [2, 0, 0], [0, 5, 0]])
    2.0
    """
    points = validate_points(points)
    if len(points) <= SMALL_CLOUD:
        return float(
            min(
                centre_distance(points, first, second).min()
                for first, second in _pair_blocks(len(points))
                if len(first)
            )
        )
    _, nearest = nearest_neighbours(points)
    return float(centre_distance(points, np.arange(len(points)), nearest).min())


def colliding_pairs(points: FloatArray, radius: float) -> IntArray:
    """Unordered pairs of points whose spheres overlap: centres closer than 2r (strictly).

    Parameters
    ----------
    points : (N, 3) array of float, cm
        Sphere centres.
    radius : float, cm
        The sphere radius r.

    Returns
    -------
    (M, 2) array of int
        Index pairs, the smaller index first; (0, 2) when nothing collides.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.geometry import colliding_pairs
    >>> colliding_pairs(np.array([[0.0, 0, 0], [1, 0, 0], [5, 0, 0]]), 0.6)
    array([[0, 1]])
    """
    if len(points) <= SMALL_CLOUD:
        blocks = [
            np.stack([first, second], axis=1)[centre_distance(points, first, second) < 2 * radius]
            for first, second in _pair_blocks(len(points))
        ]
        return np.asarray(np.concatenate(blocks), dtype=np.int64).reshape(-1, 2)
    from scipy.spatial import cKDTree  # here: a small cloud needs no tree (SMALL_CLOUD)

    candidates = cKDTree(points).query_pairs(2.0 * radius, output_type="ndarray")
    if len(candidates) == 0:
        return np.empty((0, 2), dtype=np.int64)
    close = centre_distance(points, candidates[:, 0], candidates[:, 1]) < 2.0 * radius
    return np.asarray(candidates[close], dtype=np.int64)


def remove_collisions(points: FloatArray, radius: float, seed: int = 0) -> IntArray:
    """Indices of the points kept so that no two are closer than 2r, in increasing order.

    The points are visited in a random order drawn from ``seed``; a point is
    kept unless it collides with a point kept before it. So for every
    colliding pair exactly one side goes, and the same seed keeps the same set.

    Parameters
    ----------
    points : (N, 3) array of float, cm
        Sphere centres.
    radius : float, cm
        The sphere radius r; two points collide when closer than 2r.
    seed : int, default 0
        Seed of the visiting order (``numpy.random.default_rng``).

    Returns
    -------
    (K,) array of int
        The kept indices, increasing; every index when nothing collides.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.geometry import remove_collisions
    >>> remove_collisions(np.array([[0.0, 0, 0], [1, 0, 0], [5, 0, 0]]), 0.6).tolist()
    [0, 2]
    """
    pairs = colliding_pairs(points, radius)
    if len(pairs) == 0:
        return np.arange(len(points))
    partners: dict[int, list[int]] = {}
    for a, b in pairs.tolist():
        partners.setdefault(a, []).append(b)
        partners.setdefault(b, []).append(a)
    order = np.random.default_rng(seed).permutation(len(points))
    kept = np.ones(len(points), dtype=bool)
    visited = np.zeros(len(points), dtype=bool)
    for index in order.tolist():
        visited[index] = True
        if any(visited[p] and kept[p] for p in partners.get(index, ())):
            kept[index] = False
    return np.flatnonzero(kept)


def make_swarm(
    points: ArrayLike,
    beta: float | None = None,
    radius: float | None = None,
    seed: int = 0,
) -> Swarm:
    """Build a :class:`Swarm` from a cloud, with ``r = beta * dmin`` or an explicit ``radius``.

    With beta > 0.5 some spheres collide, and one FLS of each colliding pair is
    removed first (:func:`remove_collisions`, seeded); ``Swarm.cloud_index``
    maps the FLSs kept back to the cloud's rows (spec, section 2).

    Parameters
    ----------
    points : (N, 3) array_like of float, cm
        The cloud, N >= 2, no duplicates.
    beta : float, optional
        The ratio r / dmin, in (0, 1]; the radius comes from it unless
        ``radius`` is given (it is kept in ``Swarm.beta`` either way).
    radius : float, optional, cm
        An explicit FLS radius r > 0.
    seed : int, default 0
        Seed of the collision removal's visiting order.

    Returns
    -------
    Swarm
        The FLSs kept (cm), their radius, the cloud's dmin, beta, the kept
        indices and how many were removed.

    Raises
    ------
    CloudError
        ``points`` is not an (N, 3) finite array with N >= 2, has duplicate
        points (dmin = 0), neither beta nor radius is given, beta is outside
        (0, 1], radius is not a positive number, or fewer than two FLSs remain.

    Examples
    --------
    >>> from swazure_ros.core.geometry import make_swarm
    >>> swarm = make_swarm([[0, 0, 0], [2, 0, 0], [0, 5, 0]], beta=0.25)
    >>> swarm.dmin, swarm.radius, swarm.size, swarm.removed
    (2.0, 0.5, 3, 0)
    >>> make_swarm([[0, 0, 0], [1, 0, 0], [5, 0, 0]], radius=0.6).cloud_index.tolist()
    [0, 2]
    """
    points = validate_points(points)
    dmin = min_distance(points)
    if dmin <= 0:
        raise CloudError("the cloud has duplicate points (dmin = 0); remove them first")
    if radius is None:
        if beta is None:
            raise CloudError("give beta (r = beta * dmin) or an explicit radius")
        if not math.isfinite(beta) or not 0 < beta <= 1:
            raise CloudError(f"beta must be in (0, 1], got {beta}")
        radius = beta * dmin
    elif not math.isfinite(radius) or radius <= 0:
        raise CloudError(f"radius must be a positive number of cm, got {radius}")
    kept = remove_collisions(points, radius, seed)
    if len(kept) < 2:
        raise CloudError("fewer than two FLSs remain after collision removal")
    return Swarm(
        points=points[kept],
        radius=float(radius),
        dmin=dmin,
        beta=beta if beta is not None else None,
        cloud_index=kept,
        removed=len(points) - len(kept),
    )
