"""Neighbour pairs of a swarm and their range classes (blind, sweet, decaying)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import csr, jit
from .arrays import BoolArray, FloatArray, IntArray
from .geometry import KISSING_TOLERANCE, Swarm, centre_distance
from .grid import Grid, grid_of
from .pair_scan import EVERY_PAIR, Affordable, counts_within, pairs_within
from .sensor import BLIND, DECAYING, SWEET, Sensor

if TYPE_CHECKING:
    from scipy.spatial import cKDTree


def _pieces(pieces: list[NDArray[Any]], like: NDArray[Any]) -> NDArray[Any]:
    """``pieces`` as one array; with none, an empty array of ``like``'s type."""
    return np.concatenate(pieces) if pieces else like[:0].copy()


#: A neighbour grid's cells per reach (:func:`neighbour_grid`): at 2 a search reads
#: cells that cover about 3.4 times the ball of its reach, at 1 (27 cells) 6.4 times.
#: The race car at 65,536 points: its candidate pairs counted in 1.5 s against 1.8 s, a
#: block of 4,000 FLSs' 42.5 M pairs found in 1.7 s against 6.1 s; 3 saves little more.
CELLS_PER_REACH = 2


#: The fields of :class:`NeighbourPairs`, in order.
FIELDS = ("first", "second", "distance", "tracking", "range_class")


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

    def select(self, mask: NDArray[np.bool_] | IntArray) -> NeighbourPairs:
        """The pairs where ``mask`` holds, or at the indices it lists, in its order.

        Parameters
        ----------
        mask : (M,) array of bool, or (K,) array of int

        Returns
        -------
        NeighbourPairs
        """
        return NeighbourPairs(
            self.first[mask],
            self.second[mask],
            self.distance[mask],
            self.tracking[mask],
            self.range_class[mask],
        )

    @classmethod
    def joined(cls, parts: Sequence[NeighbourPairs]) -> NeighbourPairs:
        """Pair lists as one, in the order given (blocks in order give a sorted list)."""
        return cls(*(np.concatenate([getattr(part, name) for part in parts]) for name in FIELDS))

    @classmethod
    def from_pieces(cls, columns: dict[str, list[NDArray[Any]]]) -> NeighbourPairs:
        """Pairs given field by field in pieces, as one list in the order given.

        ``columns`` holds, for each name of :data:`FIELDS`, its pieces in order, and is
        emptied as it is read: each field's pieces are let go once joined, so the
        pairs are held about once, not twice (a display's sweet pairs: 225 MB).
        """
        return cls(*(np.concatenate(columns.pop(name)) for name in FIELDS))

    def merged(
        self, columns: dict[str, list[NDArray[Any]]], size: int
    ) -> tuple[NeighbourPairs, BoolArray]:
        """These pairs and others given field by field, as one list sorted by (first, second).

        Both lists are sorted and share no pair (a neighbourhood's sweet pairs,
        and its decaying pairs in sight block by block), so the result is a
        merge: no sort, and one field built at a time. ``columns`` is emptied
        as it is read, so that each field's pieces are let go once placed: a
        display's decaying pairs in sight are tens of millions.

        Parameters
        ----------
        columns : dict of str to list of arrays
            For each name of :data:`FIELDS`, the other pairs' values in pieces
            (concatenated in order, a sorted list of pairs, none of them here).
        size : int
            N, more than any FLS index of either.

        Returns
        -------
        merged : NeighbourPairs
            Every pair of both, sorted.
        from_columns : (len(merged),) ndarray of bool
            Where a pair came from ``columns``.
        """
        other_keys = _pieces(columns["first"], self.first) * size
        other_keys += _pieces(columns["second"], self.second)
        # The other pairs' places among all: how many of these come before each, plus its rank.
        places = np.searchsorted(self.first * size + self.second, other_keys)
        del other_keys
        places += np.arange(len(places))
        from_columns = np.zeros(len(self) + len(places), dtype=bool)
        from_columns[places] = True
        del places
        fields = []
        for name in FIELDS:
            mine = getattr(self, name)
            merged_field = np.empty(len(from_columns), dtype=mine.dtype)
            merged_field[from_columns] = _pieces(columns.pop(name), mine)
            merged_field[~from_columns] = mine
            fields.append(merged_field)
        return NeighbourPairs(*fields), from_columns

    def count(self, range_class: int) -> int:
        """Number of unordered pairs of one range class.

        Parameters
        ----------
        range_class : int
            ``sensor.CONTACT``, ``BLIND``, ``SWEET``, ``DECAYING`` or ``OUT_OF_RANGE``.

        Returns
        -------
        int
        """
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
        """Index of the pair {one[m], other[m]} for each m, either order; -1 if absent.

        Parameters
        ----------
        one, other : (M,) array_like of int
            FLS indices.

        Returns
        -------
        (M,) array of int
            Positions in these pairs' arrays.
        """
        one = np.asarray(one, dtype=np.int64)
        other = np.asarray(other, dtype=np.int64)
        return np.asarray(_pair_index(self._rows, self.second, one, other))


@dataclass(frozen=True)
class NeighbourCounts:
    """How many unordered pairs a swarm has of each kind the summary reports."""

    kissing: int  # tracking distance within 1e-3 cm of 0
    sweet: int
    decaying: int

    @classmethod
    def of(cls, pairs: NeighbourPairs) -> NeighbourCounts:
        """The counts of ``pairs``."""
        return cls(pairs.kissing(), pairs.count(SWEET), pairs.count(DECAYING))

    def __add__(self, other: NeighbourCounts) -> NeighbourCounts:
        return NeighbourCounts(
            self.kissing + other.kissing, self.sweet + other.sweet, self.decaying + other.decaying
        )


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


def neighbour_grid(swarm: Swarm, sensor: Sensor, longest: float | None = None) -> Grid:
    """The grid the neighbour searches read: cells of half :func:`candidate_reach`.

    A search round an FLS reads the cells its reach touches (:data:`CELLS_PER_REACH`).

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    longest : float, optional
        As :func:`candidate_reach` takes it: the pairs to be found are shorter.

    Returns
    -------
    Grid
    """
    points = np.ascontiguousarray(swarm.points, dtype=np.float64)
    return grid_of(points, candidate_reach(sensor, swarm.radius, longest) / CELLS_PER_REACH)


def sensor_reach(sensor: Sensor, radius: float, longest: float | None = None) -> float:
    """The centre distance (cm) below which two FLSs of ``radius`` cm may be neighbours.

    ``decaying_max + 2r``, and at least a kissing pair's distance.

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.
    longest : float, optional
        A tracking distance, cm, below which pairs are asked for, when shorter
        than ``sensor.decaying_max``.

    Returns
    -------
    float, cm

    Examples
    --------
    >>> from swazure_ros.core.neighbours import sensor_reach
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor_reach(Sensor(6.0, 8.0, 8.0, 30.0), 0.5)
    31.0
    """
    farthest = sensor.decaying_max if longest is None else min(longest, sensor.decaying_max)
    return max(farthest + 2.0 * radius, 2.0 * radius + 2 * KISSING_TOLERANCE)


def candidate_reach(sensor: Sensor, radius: float, longest: float | None = None) -> float:
    """The reach of candidate pairs, cm: a rounding margin over :func:`sensor_reach`.

    The grid search finds candidates a little beyond the reach, and
    :func:`~swazure_ros.core.geometry.centre_distance` decides.

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.
    longest : float, optional
        As :func:`sensor_reach`'s.

    Returns
    -------
    float, cm
        :func:`sensor_reach` times (1 + 1e-9).
    """
    # The distances that decide are centre_distance's, not the grid search's.
    return sensor_reach(sensor, radius, longest) * (1.0 + 1e-9)


def neighbour_pairs(
    swarm: Swarm,
    sensor: Sensor,
    start: int = 0,
    stop: int | None = None,
    grid: Grid | None = None,
    involving: BoolArray | None = None,
    longest: float | None = None,
    affordable: Affordable = EVERY_PAIR,
    shortest: float | None = None,
) -> NeighbourPairs:
    """Every unordered pair with tracking distance below ``sensor.decaying_max``, classified.

    Pairs are sorted by (first, second), with their centre and tracking
    distances and range class (spec, section 3). A compiled pass over a grid
    of cells one reach wide, parallel over FLSs: no sort of the pairs.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    start, stop : int, optional
        Only the pairs whose ``first`` is in [start, stop) (default: every
        FLS): a block of the whole swarm's list, found in a block's memory.
    grid : Grid, optional
        :func:`neighbour_grid`'s, when the caller keeps it.
    involving : (N,) array of bool, optional
        Only the pairs with an FLS True here: the whole list's selection of
        them, found without the whole list.
    longest : float, optional
        Only the pairs with tracking distance below this, cm, when it is
        below ``sensor.decaying_max``: a grid of smaller cells, and fewer
        pairs measured. ``grid``, if given, must be of at least this reach.
    affordable : Affordable, optional
        Only the pairs it affords (default: every pair), found without the
        others: a search that can use few of the pairs within reach.
    shortest : float, optional
        Only the pairs with tracking distance at least this, cm, found
        without the nearer ones: ``sensor.sweet_min`` leaves out the blind
        and contact pairs, which no path hops over.

    Returns
    -------
    NeighbourPairs
        M pairs, first < second; contact pairs (t <= 0) included.

    Raises
    ------
    ValueError
        ``involving`` or ``affordable.spare`` is not one value per FLS.

    Examples
    --------
    >>> from swazure_ros.core.neighbours import neighbour_pairs
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0)  # blind < 6 <= sweet < 8 <= decaying < 30 cm
    >>> swarm = make_swarm([[0, 0, 0], [4, 0, 0], [11, 0, 0], [40, 0, 0]], radius=0.5)
    >>> pairs = neighbour_pairs(swarm, sensor)
    >>> pairs.first.tolist(), pairs.second.tolist(), pairs.tracking.tolist()
    ([0, 0, 1, 2], [1, 2, 2, 3], [3.0, 10.0, 6.0, 28.0])
    >>> pairs.range_class.tolist()  # BLIND, DECAYING, SWEET, DECAYING
    [1, 3, 2, 3]
    """
    stop = swarm.size if stop is None else stop
    farthest = sensor.decaying_max if longest is None else min(longest, sensor.decaying_max)
    reach = candidate_reach(sensor, swarm.radius, farthest)
    points = np.ascontiguousarray(swarm.points, dtype=np.float64)
    grid = grid if grid is not None else neighbour_grid(swarm, sensor, farthest)
    if involving is not None and involving.shape != (swarm.size,):
        raise ValueError(f"`involving` must be ({swarm.size},) bools, got {involving.shape}")
    spare = np.shape(affordable.spare)
    if spare != (0,) and spare != (swarm.size,):
        raise ValueError(f"`affordable.spare` must be ({swarm.size},) values, got {spare}")
    # A hair nearer than the shortest: the distances that decide are centre_distance's.
    nearest = 0.0 if shortest is None else (shortest + 2.0 * swarm.radius) * (1.0 - 1e-9)
    rows, second = pairs_within(
        points, reach, grid, start, stop, involving, affordable, max(nearest, 0.0)
    )
    first = np.repeat(np.arange(start, stop, dtype=np.int64), np.diff(rows))
    distance = centre_distance(swarm.points, first, second)
    tracking = distance - 2.0 * swarm.radius
    keep = tracking < farthest
    if shortest is not None:
        keep &= tracking >= shortest
    # Candidates come from the sensor's reach plus a rounding margin, so nearly always
    # every one is kept: copying four arrays of 6.8 M pairs for nothing took 0.25 s.
    if not keep.all():
        first, second, distance, tracking = (
            first[keep], second[keep], distance[keep], tracking[keep]
        )  # fmt: skip
    return NeighbourPairs(first, second, distance, tracking, sensor.classify(tracking))


def pair_counts(swarm: Swarm, sensor: Sensor, grid: Grid | None = None) -> IntArray:
    """Candidate pairs of each FLS as ``first`` (:func:`neighbour_pairs`'s, a few more).

    A counting pass of the neighbour kernel, storing no pair: the engine cuts
    the swarm into blocks of FLSs whose pairs fit its memory with it.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    grid : Grid, optional
        :func:`neighbour_grid`'s, when the caller keeps it.

    Returns
    -------
    (N,) array of int
        Per FLS, the candidate pairs with an FLS of a larger index.

    Examples
    --------
    >>> from swazure_ros.core.neighbours import pair_counts
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0)  # blind < 6 <= sweet < 8 <= decaying < 30 cm
    >>> swarm = make_swarm([[0, 0, 0], [4, 0, 0], [11, 0, 0], [40, 0, 0]], radius=0.5)
    >>> pair_counts(swarm, sensor).tolist()
    [2, 1, 1, 0]
    """
    reach = candidate_reach(sensor, swarm.radius)
    points = np.ascontiguousarray(swarm.points, dtype=np.float64)
    grid = grid if grid is not None else neighbour_grid(swarm, sensor)
    return np.asarray(counts_within(points, reach, grid))


def pairs_of(
    swarm: Swarm, sensor: Sensor, flss: IntArray, tree: cKDTree | None = None
) -> NeighbourPairs:
    """The pairs of :func:`neighbour_pairs` that involve an FLS of ``flss`` (sorted indices).

    The same pairs, distances and classes as the whole swarm's, found from
    the ``flss`` alone: the neighbourhood of a few FLSs, or of those that
    moved (``evaluate.neighbourhood_of``, ``evaluate.moved_neighbourhood``).

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    flss : (K,) array of int
        FLS indices, sorted.
    tree : scipy.spatial.cKDTree, optional
        A tree of ``swarm.points``, when the caller keeps one.

    Returns
    -------
    NeighbourPairs
        Each pair once, sorted by (first, second).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.neighbours import pairs_of
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0)  # blind < 6 <= sweet < 8 <= decaying < 30 cm
    >>> swarm = make_swarm([[0, 0, 0], [4, 0, 0], [11, 0, 0], [40, 0, 0]], radius=0.5)
    >>> found = pairs_of(swarm, sensor, np.array([3]))
    >>> found.first.tolist(), found.second.tolist()
    ([2], [3])
    """
    reach = sensor_reach(sensor, swarm.radius)
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
    """The pairs {one[m], other[m]} within sensor reach, as :func:`neighbour_pairs` has them.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    one, other : (M,) array of int
        FLS indices; either order, repeats allowed.

    Returns
    -------
    NeighbourPairs
        Unordered, each once, sorted by (first, second); a pair of an FLS with
        itself and pairs beyond reach are left out.
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
    """Every ordered blind pair (source, target), sorted by source then target.

    Both orders of each unordered blind pair: the pairs the model computes a
    relative pose for (spec, section 5).

    Parameters
    ----------
    pairs : NeighbourPairs

    Returns
    -------
    sources, targets : (B,) array of int
        B = twice the blind unordered pairs.

    Examples
    --------
    >>> from swazure_ros.core.neighbours import neighbour_pairs, ordered_blind_pairs
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0)  # blind < 6 <= sweet < 8 <= decaying < 30 cm
    >>> swarm = make_swarm([[0, 0, 0], [4, 0, 0], [11, 0, 0], [40, 0, 0]], radius=0.5)
    >>> sources, targets = ordered_blind_pairs(neighbour_pairs(swarm, sensor))
    >>> sources.tolist(), targets.tolist()
    ([0, 1], [1, 0])
    """
    blind = pairs.range_class == BLIND
    size = int(pairs.second.max()) + 1 if len(pairs) else 0
    rows, targets = ordered_rows(size, pairs.first[blind], pairs.second[blind])
    return csr.run_of(rows), targets


def ordered_rows(size: int, first: IntArray, second: IntArray) -> tuple[IntArray, IntArray]:
    """Unordered pairs as both orders, in compressed sparse rows over ``size`` FLSs.

    Parameters
    ----------
    size : int
        FLSs, more than every index.
    first, second : (M,) array of int
        Unordered pairs, each once.

    Returns
    -------
    rows : (size + 1,) array of int
        Row i's targets are ``targets[rows[i]:rows[i + 1]]``.
    targets : (2M,) array of int
        Sorted within each row.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.neighbours import ordered_rows
    >>> rows, targets = ordered_rows(4, np.array([0, 1]), np.array([1, 2]))
    >>> rows.tolist(), targets.tolist()
    ([0, 1, 3, 4, 4], [1, 0, 2, 1])
    """
    from .graph import symmetric_rows  # a graph's rows are the ordered pairs, sorted

    rows, targets, _ = symmetric_rows(size, first, second, edges=False)
    return rows, targets
