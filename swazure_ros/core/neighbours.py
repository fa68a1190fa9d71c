"""Neighbour pairs of a swarm and their range classes (blind, sweet, decaying)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .geometry import KISSING_TOLERANCE, Swarm, centre_distance
from .sensor import BLIND, Sensor

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class NeighbourPairs:
    """Unordered pairs (first < second) within sensor reach, with their range class."""

    first: IntArray  # (M,)
    second: IntArray  # (M,)
    distance: FloatArray  # (M,), centre distance, cm
    tracking: FloatArray  # (M,), tracking distance, cm
    range_class: NDArray[np.int8]  # (M,), sensor.CONTACT ... OUT_OF_RANGE

    def __len__(self) -> int:
        return len(self.first)

    def select(self, mask: NDArray[np.bool_]) -> NeighbourPairs:
        """The pairs where ``mask`` holds."""
        return NeighbourPairs(
            self.first[mask],
            self.second[mask],
            self.distance[mask],
            self.tracking[mask],
            self.range_class[mask],
        )

    def count(self, range_class: int) -> int:
        """Number of unordered pairs of one range class."""
        return int(np.count_nonzero(self.range_class == range_class))

    def kissing(self) -> int:
        """Number of unordered pairs whose tracking distance is within 1e-3 cm of 0."""
        return int(np.count_nonzero(np.abs(self.tracking) <= KISSING_TOLERANCE))

    @cached_property
    def _rows(self) -> IntArray:
        """Start of each FLS's pairs as ``first``: (N + 1,), N the largest index + 1."""
        size = int(self.second.max()) + 1 if len(self.second) else 0
        return csr.offsets(np.bincount(self.first, minlength=size)).astype(np.int64)

    def index(self, one: ArrayLike, other: ArrayLike) -> IntArray:
        """Index of the pair {one[m], other[m]} for each m, either order: (M,); -1 if absent."""
        one = np.asarray(one, dtype=np.int64)
        other = np.asarray(other, dtype=np.int64)
        return np.asarray(_pair_index(self._rows, self.second, one, other))


@jit.kernel(cache=True, parallel=True)
def _pair_index(rows: IntArray, second: IntArray, one: IntArray, other: IntArray) -> IntArray:
    out = np.full(len(one), -1, dtype=np.int64)
    for m in jit.prange(len(one)):
        low, high = min(one[m], other[m]), max(one[m], other[m])
        if low == high or low + 1 >= len(rows):
            continue
        start, stop = rows[low], rows[low + 1]
        position = start + np.searchsorted(second[start:stop], high)
        if position < stop and second[position] == high:
            out[m] = position
    return out


def neighbour_pairs(swarm: Swarm, sensor: Sensor) -> NeighbourPairs:
    """Every unordered pair with tracking distance below ``sensor.decaying_max``, classified.

    Pairs are sorted by (first, second).
    """
    reach = sensor.decaying_max + 2.0 * swarm.radius
    reach = max(reach, 2.0 * swarm.radius + 2 * KISSING_TOLERANCE)
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    candidates = cKDTree(swarm.points).query_pairs(reach, output_type="ndarray")
    candidates = np.asarray(candidates, dtype=np.int64).reshape(-1, 2)
    first, second = candidates[:, 0], candidates[:, 1]
    distance = centre_distance(swarm.points, first, second)
    tracking = distance - 2.0 * swarm.radius
    keep = tracking < sensor.decaying_max
    # One int64 key per pair (unique): a third of lexsort's time on the race car.
    order = np.argsort(first[keep] * swarm.size + second[keep])
    first, second = first[keep][order], second[keep][order]
    distance, tracking = distance[keep][order], tracking[keep][order]
    return NeighbourPairs(first, second, distance, tracking, sensor.classify(tracking))


def pairs_of(
    swarm: Swarm, sensor: Sensor, flss: IntArray, tree: cKDTree | None = None
) -> NeighbourPairs:
    """The pairs of :func:`neighbour_pairs` that involve an FLS of ``flss`` (sorted indices).

    The same pairs, distances and classes as the whole swarm's, found from
    the ``flss`` alone. ``tree`` is a cKDTree of the swarm's points, when the
    caller keeps one.
    """
    reach = sensor.decaying_max + 2.0 * swarm.radius
    reach = max(reach, 2.0 * swarm.radius + 2 * KISSING_TOLERANCE)
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    tree = tree if tree is not None else cKDTree(swarm.points)
    found = tree.query_ball_point(swarm.points[flss], reach)
    counts = np.array([len(near) for near in found], dtype=np.int64)
    one = np.repeat(np.asarray(flss, dtype=np.int64), counts)
    other = (
        np.concatenate([np.asarray(near, dtype=np.int64) for near in found])
        if len(found)
        else np.zeros(0, dtype=np.int64)
    )
    return pairs_between(swarm, sensor, one, other)


def pairs_between(swarm: Swarm, sensor: Sensor, one: IntArray, other: IntArray) -> NeighbourPairs:
    """The pairs {one[m], other[m]} (M,) within sensor reach, as :func:`neighbour_pairs` has them.

    Unordered, each once, sorted; a pair of an FLS with itself is left out.
    """
    one, other = np.asarray(one, dtype=np.int64), np.asarray(other, dtype=np.int64)
    first, second = np.minimum(one, other), np.maximum(one, other)
    keys = np.unique((first * swarm.size + second)[first != second])
    first, second = keys // swarm.size, keys % swarm.size
    distance = centre_distance(swarm.points, first, second)
    tracking = distance - 2.0 * swarm.radius
    keep = tracking < sensor.decaying_max
    first, second, distance, tracking = first[keep], second[keep], distance[keep], tracking[keep]
    return NeighbourPairs(first, second, distance, tracking, sensor.classify(tracking))


def ordered_blind_pairs(pairs: NeighbourPairs) -> tuple[IntArray, IntArray]:
    """Every ordered blind pair (source, target), sorted by source then target."""
    blind = pairs.range_class == BLIND
    source = np.concatenate([pairs.first[blind], pairs.second[blind]])
    target = np.concatenate([pairs.second[blind], pairs.first[blind]])
    order = np.lexsort((target, source))
    return source[order], target[order]
