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
from numpy.typing import ArrayLike, NDArray

from .clouds import validate_points
from .errors import CloudError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

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


def centre_distance(points: FloatArray, first: ArrayLike, second: ArrayLike) -> FloatArray:
    """Centre-to-centre distances |p_second - p_first|, cm, for index arrays of one shape."""
    offset = points[np.asarray(second)] - points[np.asarray(first)]
    return np.asarray(np.sqrt(np.einsum("...k,...k->...", offset, offset)), dtype=np.float64)


def tracking_distance(
    points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> FloatArray:
    """Surface-to-surface distances |p_second - p_first| - 2r, cm."""
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
    """dmin: the smallest centre-to-centre distance between two points, cm."""
    points = validate_points(points)
    if len(points) <= SMALL_CLOUD:
        return float(
            min(
                centre_distance(points, first, second).min()
                for first, second in _pair_blocks(len(points))
                if len(first)
            )
        )
    from scipy.spatial import cKDTree  # here: a small cloud needs no tree (SMALL_CLOUD)

    _, nearest = cKDTree(points).query(points, k=2)
    return float(centre_distance(points, np.arange(len(points)), nearest[:, 1]).min())


def colliding_pairs(points: FloatArray, radius: float) -> IntArray:
    """Unordered pairs (M, 2) of points closer than 2r (strictly)."""
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

    Raises CloudError for duplicate points (dmin = 0) and for a missing or
    out-of-range beta or radius.
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
