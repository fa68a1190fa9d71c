"""What each FLS observes: camera measurements and radio detections (spec, sections 3 and 4).

The camera of FLS ``i`` measures FLS ``j`` when ``j`` is in sweet or decaying
range and in line of sight; the measured vector follows the sensor's error
model. Radio tells ``i`` which FLSs are in its blind, sweet and decaying
ranges and how far they are (the tracking distance t, which the path policies
weigh hops by), line of sight ignored. Both are views of one
:class:`~.neighbourhood.Neighbourhood`, laid out per FLS (CSR) so that a node can
take its own slice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray, IntArray
from .geometry import Swarm, centre_distance
from .graph import symmetric_rows
from .grid import Grid
from .hop_errors import measured_vectors
from .neighbourhood import Neighbourhood
from .sensor import BLIND, DECAYING, SWEET, Sensor
from .sight import obstructed

#: Camera readings worked out at once, at most (rows): their temporaries take ~100 B a row.
CAMERA_BLOCK = 1 << 20


@dataclass(frozen=True)
class Measurement:
    """One FLS's camera measurements: target ids, range classes, vectors (cm), t' (cm)."""

    target_ids: IntArray  # (K,)
    range_class: NDArray[np.int8]  # (K,), SWEET or DECAYING
    vector: FloatArray  # (K, 3)
    tracking: FloatArray  # (K,)

    def same_as(self, other: Measurement) -> bool:
        """True when ``other`` measures the same FLSs the same way, to the bit."""
        return (
            np.array_equal(self.target_ids, other.target_ids)
            and np.array_equal(self.range_class, other.range_class)
            and np.array_equal(self.vector, other.vector)
            and np.array_equal(self.tracking, other.tracking)
        )


@dataclass(frozen=True)
class Observations:
    """Every FLS's neighbours within sensor reach, decaying ones in sight only, grouped by
    FLS (swarm indices).

    Rows ``indptr[i]:indptr[i+1]`` belong to FLS ``i``, sorted by ``other``.
    The camera's readings are held for the rows it looks at (sweet or
    decaying, in line of sight) only, row ``reading[e]`` of ``readings_vector``
    and ``readings_tracking`` (-1: none): most rows of a display are out of
    sight, and a reading is 32 bytes. :meth:`vector_at` and :meth:`tracking_at`
    give them by row, NaN where the camera reads nothing.
    """

    indptr: IntArray  # (N + 1,)
    other: IntArray  # (E,)
    range_class: NDArray[np.int8]  # (E,), BLIND, SWEET or DECAYING
    visible: NDArray[np.bool_]  # (E,), line of sight
    distance: FloatArray  # (E,), tracking distance t as radio ranging reports it, cm
    reading: NDArray[np.int32]  # (E,), the row's reading; -1 where the camera does not look
    readings_vector: FloatArray  # (R, 3), measured vector owner -> other, cm; NaN: undetected
    readings_tracking: FloatArray  # (R,), measured tracking distance t', cm

    @property
    def vector(self) -> FloatArray:
        """(E, 3) every row's measured vector, cm, NaN without a reading: made whole."""
        return self.vector_at(slice(None))

    @property
    def tracking(self) -> FloatArray:
        """(E,) every row's measured t', cm, NaN without a reading: made whole."""
        return self.tracking_at(slice(None))

    def vector_at(self, rows: slice | IntArray) -> FloatArray:
        """(K, 3) the measured vectors of rows ``rows``, cm; NaN where there is no reading."""
        return _vectors(self.reading[rows], self.readings_vector)

    def tracking_at(self, rows: slice | IntArray) -> FloatArray:
        """(K,) the measured t' of rows ``rows``, cm; NaN where there is no reading."""
        reading = self.reading[rows]
        out = np.full(len(reading), np.nan)
        looked = reading >= 0
        out[looked] = self.readings_tracking[reading[looked]]
        return out

    @property
    def measured(self) -> NDArray[np.bool_]:
        """(E,) the camera measures the pair: sweet or decaying, in line of sight."""
        return self.measured_in(slice(None))

    def measured_in(self, rows: slice | IntArray) -> NDArray[np.bool_]:
        """``measured`` for the rows ``rows`` only (one FLS's, from :meth:`rows`)."""
        # A row with a reading is sweet or decaying and in sight; a rendering camera may
        # still not have detected the marker (NaN).
        reading = self.reading[rows]
        measured = reading >= 0
        measured[measured] = np.isfinite(self.readings_vector[reading[measured], 0])
        return measured

    def rows(self, fls: int) -> slice:
        """The rows of FLS ``fls`` (a swarm index)."""
        return slice(int(self.indptr[fls]), int(self.indptr[fls + 1]))


@dataclass(frozen=True)
class NeighbourSets:
    """One FLS's neighbours as it knows them, as sorted swarm indices."""

    blind: IntArray  # by radio
    sweet: IntArray  # by radio: S_all
    visible_sweet: IntArray  # by camera: S_vis
    visible_decaying: IntArray  # by camera: decaying with line of sight


def observations(hood: Neighbourhood, owners: IntArray | None = None) -> Observations:
    """Lay out the blind, sweet and decaying-in-sight pairs of ``hood`` per FLS, both directions.

    What every FLS senses that the protocol uses: its blind and sweet neighbours
    by radio (the tracking distance t, line of sight ignored), its decaying
    neighbours in sight, and, for the sweet and decaying ones in sight, its
    camera's reading. A decaying neighbour out of sight is no row: no hop, no
    reading and no neighbour set takes it, and at display scale it is half of
    what a process would hold (docs/swarm.md).

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's pairs and their line of sight.
    owners : (K,) array of int, optional
        Swarm indices: only those FLSs' rows are laid out (the others' are
        empty), so that a process hosting a share of the swarm holds what its
        own FLSs sense, not the whole swarm's. Default: every FLS.

    Returns
    -------
    Observations
        E rows (each pair once from each owner's side), grouped by owner,
        sorted by the other FLS; vectors and t' in cm, NaN where the camera
        reads nothing.

    Raises
    ------
    ValueError
        More camera readings than a row's int32 index holds (2^31 - 1).
    """
    # Column by column, each laid out and its temporaries gone before the next: the rows
    # of torus:10000 (31.5 M pairs) held 2.9 GB, and building them all at once peaked at 5.4.
    pairs, size = hood.pairs, hood.swarm.size
    # A decaying neighbour out of sight is nobody's hop, reading or neighbour set (radio
    # neighbours are blind and sweet ones): half a display's rows, not laid out.
    in_sight = (pairs.range_class == DECAYING) & hood.visible
    keep = np.flatnonzero(np.isin(pairs.range_class, (BLIND, SWEET)) | in_sight)
    del in_sight
    hosted = None
    if owners is not None:
        hosted = np.zeros(size, dtype=bool)
        hosted[np.asarray(owners, dtype=np.int64)] = True
        keep = keep[hosted[pairs.first[keep]] | hosted[pairs.second[keep]]]
    # Each pair from both ends, grouped by owner and sorted by the other, laid out in
    # linear time (the pairs come sorted; an argsort took 1.4 s of the race car's 2.6).
    indptr, other, pair = symmetric_rows(size, pairs.first[keep], pairs.second[keep], hosted)
    pair = keep[pair]
    del keep
    true_tracking = pairs.tracking[pair]
    range_class = pairs.range_class[pair]
    visible = hood.visible[pair]
    del pair
    looked = visible & ((range_class == SWEET) | (range_class == DECAYING))
    measured = np.flatnonzero(looked)
    measured_owner = np.searchsorted(indptr, measured, side="right") - 1
    if len(measured) > np.iinfo(np.int32).max:
        raise ValueError(f"{len(measured)} camera readings: more than a row index holds")
    reading = np.full(len(other), -1, dtype=np.int32)
    reading[measured] = np.arange(len(measured), dtype=np.int32)
    del looked
    vector = np.empty((len(measured), 3))
    tracking = np.empty(len(measured))
    # The readings in blocks: each pair's is its own (its own seeded draw), and a block's
    # temporaries stay small.
    for start in range(0, len(measured), CAMERA_BLOCK):
        block = slice(start, start + CAMERA_BLOCK)
        rows = measured[block]
        vector[block], tracking[block] = camera_readings(
            hood.swarm, hood.sensor, measured_owner[block], other[rows], true_tracking[rows]
        )
    return Observations(
        indptr, other, range_class, visible, true_tracking, reading, vector, tracking
    )


@dataclass(frozen=True)
class Readings:
    """What one FLS's camera measures of some FLSs (M of them, swarm indices, sorted)."""

    other: IntArray  # (M,)
    range_class: NDArray[np.int8]  # (M,), SWEET or DECAYING
    vector: FloatArray  # (M, 3), measured vector owner -> other, cm
    tracking: FloatArray  # (M,), measured tracking distance t', cm


def readings_of(
    swarm: Swarm, sensor: Sensor, owner: int, others: ArrayLike, grid: Grid | None = None
) -> Readings:
    """What FLS ``owner`` (a swarm index) measures of the FLSs at indices ``others`` (K,).

    The rows of ``observations`` for these pairs where ``measured`` holds,
    worked out for these pairs alone: a path walk's FLS measures its next hop,
    one pair, in a world revision that nobody has laid out whole.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    owner : int
        The measuring FLS, a swarm index.
    others : (K,) array_like of int
        The FLSs it looks at; repeats and ``owner`` itself are dropped.
    grid : Grid, optional
        ``grid.build_grid`` of the swarm, when the caller keeps it.

    Returns
    -------
    Readings
        Only the FLSs the camera reads: sweet or decaying, in line of sight,
        and detected; sorted.

    Examples
    --------
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.observe import readings_of
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm([[0, 0, 0], [4, 0, 0], [11, 0, 0], [40, 0, 0]], radius=0.5)
    >>> seen = readings_of(swarm, Sensor(6.0, 8.0, 8.0, 30.0), 1, [0, 2, 3])  # error-free
    >>> seen.other.tolist(), seen.vector.tolist(), seen.tracking.tolist()  # 0 blind, 3 too far
    ([2], [[7.0, 0.0, 0.0]], [6.0])
    """
    other = np.unique(np.asarray(others, dtype=np.int64))
    other = other[other != owner]
    hop = pair_readings(swarm, sensor, np.full(len(other), owner, dtype=np.int64), other, grid)
    return Readings(other[hop.read], hop.range_class[hop.read], hop.vector, hop.tracking)


@dataclass(frozen=True)
class PairReadings:
    """What the camera of each pair's first FLS measures of its second (M pairs)."""

    read: NDArray[np.bool_]  # (M,), sweet or decaying, in line of sight and detected
    range_class: NDArray[np.int8]  # (M,), each pair's, read or not
    vector: FloatArray  # (R, 3), cm, of the R pairs read, in order
    tracking: FloatArray  # (R,), t', cm, of the pairs read


def pair_readings(
    swarm: Swarm, sensor: Sensor, owner: IntArray, other: IntArray, grid: Grid | None = None
) -> PairReadings:
    """What FLS ``owner[k]`` measures of FLS ``other[k]`` (swarm indices), pair by pair.

    :func:`readings_of`'s work for pairs of many owners: the hops of path walks
    through a process's FLSs, read at once. Each pair's reading is its own (a
    stochastic sensor's draw is the pair's), so reading pairs together or one
    by one gives the same bits.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    owner, other : (M,) array of int
        The measuring and the measured FLS of each pair, swarm indices; a pair of
        an FLS with itself is never read.
    grid : Grid, optional
        ``grid.build_grid`` of the swarm, or a grid of its points on other cells.

    Returns
    -------
    PairReadings
    """
    owner = np.asarray(owner, dtype=np.int64)
    other = np.asarray(other, dtype=np.int64)
    true_tracking = centre_distance(swarm.points, owner, other) - 2.0 * swarm.radius
    range_class = np.asarray(sensor.classify(true_tracking), dtype=np.int8)
    seen = ((range_class == SWEET) | (range_class == DECAYING)) & (owner != other)
    seen[seen] = ~obstructed(swarm.points, swarm.radius, owner[seen], other[seen], grid)
    vector, tracking = camera_readings(
        swarm, sensor, owner[seen], other[seen], true_tracking[seen]
    )
    detected = np.isfinite(vector[:, 0])  # a rendering camera may not detect
    read = seen.copy()
    read[seen] = detected
    return PairReadings(read, range_class, vector[detected], tracking[detected])


def camera_readings(
    swarm: Swarm, sensor: Sensor, owner: IntArray, other: IntArray, true_tracking: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """What each ``owner`` reads of its ``other``: measured vectors and tracking t', cm.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    owner, other : (M,) array of int
        The measuring and the measured FLS of each pair, in camera range and
        line of sight.
    true_tracking : (M,) array of float, cm
        Each pair's tracking distance t.

    Returns
    -------
    vector : (M, 3) array of float, cm
        :func:`~.hop_errors.measured_vectors`; NaN where a rendering camera did
        not detect the marker.
    tracking : (M,) array of float, cm
        The measured t': the error model's, or the vector's length less 2r
        when the noise or the rendered frame is in the vector.
    """
    vector = measured_vectors(sensor, swarm.points, swarm.radius, owner, other)
    if sensor.noise is None and sensor.camera is None:
        return vector, sensor.measured_tracking(true_tracking)
    # The drawn noise or the rendered frame is in the vector; its length says what was
    # measured (NaN where the camera did not detect the marker: no reading).
    return vector, np.linalg.norm(vector, axis=1) - 2.0 * swarm.radius


def _vectors(reading: NDArray[np.int32], readings_vector: FloatArray) -> FloatArray:
    """(K, 3) rows' measured vectors, cm: row ``reading[k]`` of ``readings_vector``, NaN
    where ``reading[k]`` is -1 (no reading)."""
    out = np.full((len(reading), 3), np.nan)
    looked = reading >= 0
    out[looked] = readings_vector[reading[looked]]
    return out


@dataclass(frozen=True)
class LocalView:
    """What one FLS knows of its neighbours (K of them), as FLS ids.

    Its camera's readings are kept as :class:`Observations` keeps them: row
    ``reading[k]`` of ``readings_vector`` (-1: none). A view of a world's rows
    (:func:`local_view`) thus holds them in place: every FLS of a process keeps
    its view for a whole run, and a share of a display has thousands of rows per FLS.
    """

    fls_id: int
    other: IntArray  # (K,), FLS ids
    range_class: NDArray[np.int8]  # (K,), BLIND, SWEET or DECAYING
    visible: NDArray[np.bool_]  # (K,), camera line of sight
    distance: FloatArray  # (K,), tracking distance by radio, cm
    reading: NDArray[np.int32]  # (K,), the row's reading; -1 where the camera does not look
    readings_vector: FloatArray  # (R, 3), measured vector to the neighbour, cm; NaN: undetected

    @property
    def blind(self) -> IntArray:
        """(B,) ids of the blind neighbours."""
        return np.asarray(self.other[self.range_class == BLIND], dtype=np.int64)

    @property
    def vector(self) -> FloatArray:
        """(K, 3) the measured vector to each neighbour, cm, NaN without a reading: made
        anew at each call (take :meth:`vector_at` of the rows wanted)."""
        return self.vector_at(slice(None))

    def vector_at(self, rows: slice | NDArray[np.bool_] | IntArray) -> FloatArray:
        """(M, 3) the measured vectors of rows ``rows``, cm; NaN where there is no reading."""
        return _vectors(self.reading[rows], self.readings_vector)

    @property
    def read(self) -> NDArray[np.bool_]:
        """(K,) the camera read the neighbour: sweet or decaying, in sight, detected."""
        read = self.reading >= 0
        read[read] = np.isfinite(self.readings_vector[self.reading[read]]).all(axis=1)
        return read


#: An FLS's view with its blind and sweet neighbours only, and how to take its whole view of
#: the same moment (its decaying neighbours too), for a run that needs it later.
NearView = tuple[LocalView, Callable[[], LocalView]]


def local_view(seen: Observations, ids: IntArray, fls: int) -> LocalView:
    """The view of the FLS at swarm index ``fls``, with neighbours as FLS ids.

    It holds ``seen``'s rows in place, not copies; so do its neighbours' ids where
    ``ids`` are the swarm indices themselves (a cloud none of whose points was removed).

    Parameters
    ----------
    seen : Observations
        With ``fls``'s rows laid out.
    ids : (N,) array of int
        The FLS id of each swarm index, ascending (as a swarm's are).
    fls : int
        A swarm index.

    Returns
    -------
    LocalView
        Its neighbours by id, with range class, line of sight, radio
        distance (cm) and camera readings (cm).
    """
    rows = seen.rows(fls)
    other = seen.other[rows]
    # Ascending ids from 0 to N - 1 are 0, 1, ..., N - 1: the swarm index is the id.
    identity = len(ids) > 0 and ids[0] == 0 and ids[-1] == len(ids) - 1
    return LocalView(
        fls_id=int(ids[fls]),
        other=other if identity and other.dtype == ids.dtype else ids[other],
        range_class=seen.range_class[rows],
        visible=seen.visible[rows],
        distance=seen.distance[rows],
        reading=seen.reading[rows],
        readings_vector=seen.readings_vector,
    )


def neighbour_sets(seen: Observations, fls: int) -> NeighbourSets:
    """The neighbour sets of FLS ``fls`` (a swarm index).

    Parameters
    ----------
    seen : Observations
        With ``fls``'s rows laid out.
    fls : int
        A swarm index.

    Returns
    -------
    NeighbourSets
        Blind and sweet by radio; sweet and decaying in sight by camera; swarm
        indices, sorted.
    """
    rows = seen.rows(fls)
    other, kind, visible = seen.other[rows], seen.range_class[rows], seen.visible[rows]
    return NeighbourSets(
        blind=other[kind == BLIND],
        sweet=other[kind == SWEET],
        visible_sweet=other[(kind == SWEET) & visible],
        visible_decaying=other[(kind == DECAYING) & visible],
    )
