"""What an FLS senses: the interface an FLS node knows the world through.

An FLS knows its world through two things only: the swarm description it is
given (its id, the points of the shape the swarm displays, the sensor; a
display's shape is common knowledge of its FLSs) and what its own camera
detects. :class:`Senses` is that interface. Two kinds serve it:

- the simulator's :class:`~swazure_ros.sim.replica.WorldReplica`, which
  senses for every FLS of a process from ground truth (the packed mode);
- :class:`DetectedSenses`, one FLS's own: ranging from the shape's points and
  camera readings from the detections its camera publishes (an FLS in its own
  process, fed by the simulated sensor or by an ArUco detector on a camera).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.errors import UnknownFlsError
from ..core.geometry import tracking_distance
from ..core.lookup import sorted_rows
from ..core.observe import LocalView, Measurement, NearView, NeighbourSets
from ..core.sensor import BLIND, DECAYING, SWEET, Sensor


class Senses(Protocol):
    """The camera and radio of the FLSs a process hosts, as their nodes use them."""

    #: FLSs this process saw leave the ROS graph (liveness).
    gone: set[int]
    #: Called after the senses change (a new world revision, new detections).
    on_revision: list[Callable[[], None]]

    @property
    def sensor(self) -> Sensor:
        """The sensor every FLS measures with."""
        ...

    @property
    def radius(self) -> float:
        """The FLSs' radius, cm."""
        ...

    @property
    def ids(self) -> IntArray:
        """(N,) the swarm's FLS ids, sorted."""
        ...

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        ...

    @property
    def revision(self) -> int:
        """Counts changes of what the FLSs sense; walks wait for the revision they name."""
        ...

    def measurement(self, fls_id: int, of: Sequence[int] | None = None) -> Measurement:
        """What FLS ``fls_id``'s camera measures now (of FLSs ``of`` only)."""
        ...

    def hop_measurements(
        self, fls_ids: Sequence[int], next_ids: Sequence[int]
    ) -> list[Measurement]:
        """``measurement(fls_ids[k], [next_ids[k]])`` for each k, read at once: a path
        walk's hops through the FLSs of this process."""
        ...

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbours as it knows them now, FLS ids."""
        ...

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours, for path discovery."""
        ...

    def near_view(self, fls_id: int) -> NearView | None:
        """FLS ``fls_id``'s view with its blind and sweet neighbours only, and how to take its
        whole view of the same moment later; None where the whole view is at hand."""
        ...

    def positions(self, fls_ids: IntArray) -> FloatArray:
        """(K, 3) where FLSs ``fls_ids`` are as far as this process knows, cm."""
        ...


def classify(sensor: Sensor, tracking: FloatArray) -> NDArray[np.int8]:
    """Range classes (K,) of tracking distances (K,), cm."""
    return np.asarray(sensor.classify(tracking), dtype=np.int8)


def carried_markers(sensor: Sensor, ids: IntArray) -> IntArray:
    """(N,) the ArUco marker each FLS of ``ids`` (N,, swarm order) carries.

    The published model's camera reads an FLS's id; a rendering camera reads
    the markers its sensor file lists (FLS k carries markers[k % len]), or its
    camera file's one marker on every FLS.
    """
    ids = np.asarray(ids, dtype=np.int64)
    if sensor.camera is None:
        return ids
    if sensor.camera_markers:
        markers = np.asarray(sensor.camera_markers, dtype=np.int64)
        return markers[np.arange(len(ids)) % len(markers)]
    return np.full(len(ids), sensor.camera.marker_id, dtype=np.int64)


class DetectedSenses:
    """One FLS's senses from the shape's points and its own camera's detections.

    Ranging (which FLSs are blind, sweet or decaying neighbours, and how far)
    comes from where the FLSs are as the swarm knows it: the points each FLS is
    assigned, ``points`` (N, 3) cm of FLSs ``ids`` (N,), sorted, moved by the
    commands the swarm's heuristics give (:meth:`move`). Camera readings come
    from :meth:`detect`. A marker reads as the FLS whose place is nearest the
    measured vector among those that carry it (:func:`carried_markers`): a
    camera's dictionary is smaller than a swarm.

    :attr:`revision` is the world revision both the FLS's places and its last
    frame show: a path walk waits for it.
    """

    def __init__(
        self,
        fls_id: int,
        ids: IntArray,
        points: FloatArray,
        sensor: Sensor,
        radius: float,
    ) -> None:
        self.fls_id = fls_id
        self._ids = np.asarray(ids, dtype=np.int64)
        self._home = np.asarray(points, dtype=np.float64)
        self._points = self._home
        self._sensor = sensor
        self._radius = radius
        self._markers = carried_markers(sensor, self._ids)
        self.gone: set[int] = set()
        self.on_revision: list[Callable[[], None]] = []
        self._moves_revision = 0
        # The last frame: markers (K,), vectors (K, 3) cm, the world revision it shows.
        self._frame: tuple[IntArray, FloatArray, int] = (
            np.zeros(0, dtype=np.int64),
            np.zeros((0, 3)),
            0,
        )
        self._frames = 0
        self._range()

    def _range(self) -> None:
        """Ranging from where the FLSs are, as the simulator's computes it, to the bit."""
        row = self._row(self.fls_id)
        points, everyone = self._points, np.arange(len(self._ids))
        tracking = tracking_distance(points, self._radius, np.full_like(everyone, row), everyone)
        range_class = classify(self._sensor, tracking)
        near = np.isin(range_class, (BLIND, SWEET, DECAYING))
        near[row] = False
        # The FLS's neighbours by radio, sorted by id (as the simulator's views are).
        self._near = np.flatnonzero(near)
        self._range_class = range_class[self._near]
        self._distance = tracking[self._near]
        self._vector = np.full((len(self._near), 3), np.nan)

    def _row(self, fls_id: int) -> int:
        row = int(np.searchsorted(self._ids, fls_id))
        if row >= len(self._ids) or self._ids[row] != fls_id:
            raise UnknownFlsError(
                f"no FLS {fls_id} in this swarm of {len(self._ids)} FLSs "
                f"(ids {self._ids[0]}..{self._ids[-1]})"
            )
        return row

    @property
    def sensor(self) -> Sensor:
        """The sensor every FLS measures with."""
        return self._sensor

    @property
    def radius(self) -> float:
        """The FLSs' radius, cm."""
        return self._radius

    @property
    def ids(self) -> IntArray:
        """(N,) the swarm's FLS ids, sorted."""
        return self._ids

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        return int(self._ids[-1]) + 1

    @property
    def revision(self) -> int:
        """The world revision that both the FLSs' places and the last frame show."""
        return min(self._moves_revision, self._frame[2])

    @property
    def frames(self) -> int:
        """Frames of detections taken so far."""
        return self._frames

    def detect(self, marker_ids: IntArray, vectors: FloatArray, revision: int = 0) -> int:
        """Take one frame's readings: markers (K,), vectors (K, 3) cm centre to centre.

        ``revision``: the world revision the frame shows (0 from a camera
        driver). A marker that no FLS in camera range carries is left out.
        Returns the readings kept.
        """
        self._frame = (
            np.asarray(marker_ids, dtype=np.int64),
            np.asarray(vectors, dtype=np.float64).reshape(-1, 3),
            revision,
        )
        self._frames += 1
        kept = self._read_frame()
        self._changed()
        return kept

    def move(self, fls_ids: IntArray, points: FloatArray) -> None:
        """FLSs ``fls_ids`` (K,) were sent to ``points`` (K, 3) cm: the next world revision."""
        rows = np.array([self._row(int(fls_id)) for fls_id in fls_ids], dtype=np.int64)
        moved = self._points.copy()
        moved[rows] = points
        # Back home exactly: the simulator's world then is its home again, bit for bit.
        self._points = self._home if np.array_equal(moved, self._home) else moved
        self._moves_revision += 1
        self._range()
        self._read_frame()
        self._changed()

    def _changed(self) -> None:
        for hook in self.on_revision:
            hook()

    def _read_frame(self) -> int:
        """Read the last frame against where the FLSs now are; the readings kept."""
        marker_ids, vectors, _ = self._frame
        camera_range = (self._range_class == SWEET) | (self._range_class == DECAYING)
        candidates = self._near[camera_range]
        candidate_markers = self._markers[candidates]
        expected = self._points[candidates] - self._points[self._row(self.fls_id)]
        vector = np.full((len(self._near), 3), np.nan)
        kept = 0
        for marker, measured in zip(marker_ids.tolist(), vectors, strict=True):
            carriers = np.flatnonzero(candidate_markers == marker)
            if not len(carriers):
                continue
            # Nearest by place; on a tie, the smaller id (carriers are sorted).
            best = carriers[np.argmin(np.linalg.norm(expected[carriers] - measured, axis=1))]
            vector[np.searchsorted(self._near, candidates[best])] = measured
            kept += 1
        self._vector = vector
        return kept

    def _read(self) -> NDArray[np.bool_]:
        return np.asarray(np.isfinite(self._vector[:, 0]), dtype=np.bool_)

    def measurement(self, fls_id: int, of: Sequence[int] | None = None) -> Measurement:
        """What this FLS's camera read in its last frame (of FLSs ``of`` only)."""
        self._own(fls_id)
        read = self._read()
        if of is not None:
            read &= np.isin(self._ids[self._near], np.asarray(of, dtype=np.int64))
        vector = self._vector[read]
        return Measurement(
            self._ids[self._near[read]],
            self._range_class[read],
            vector,
            np.linalg.norm(vector, axis=1) - 2.0 * self._radius,
        )

    def hop_measurements(
        self, fls_ids: Sequence[int], next_ids: Sequence[int]
    ) -> list[Measurement]:
        """This FLS's last frame, of each hop's next FLS alone (one FLS: one hop at most)."""
        return [
            self.measurement(fls, [other]) for fls, other in zip(fls_ids, next_ids, strict=True)
        ]

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """This FLS's neighbours: by ranging, and those its camera read."""
        self._own(fls_id)
        ids, kind, read = self._ids[self._near], self._range_class, self._read()
        return NeighbourSets(
            blind=ids[kind == BLIND],
            sweet=ids[kind == SWEET],
            visible_sweet=ids[(kind == SWEET) & read],
            visible_decaying=ids[(kind == DECAYING) & read],
        )

    def view(self, fls_id: int) -> LocalView:
        """What this FLS knows of its neighbours: a neighbour is visible when it was read."""
        self._own(fls_id)
        return LocalView(
            fls_id=fls_id,
            other=self._ids[self._near],
            range_class=self._range_class,
            visible=self._read(),
            distance=self._distance,
            # Row k's reading is row k of its frame's vectors (NaN: not detected).
            reading=np.arange(len(self._near), dtype=np.int32),
            readings_vector=self._vector.copy(),
        )

    def near_view(self, fls_id: int) -> NearView | None:
        """None: an FLS alone holds its own rows only, its whole view at hand."""
        self._own(fls_id)
        return None

    def positions(self, fls_ids: IntArray) -> FloatArray:
        """(K, 3) where FLSs ``fls_ids`` are as the swarm knows it, cm."""
        wanted = np.asarray(fls_ids, dtype=np.int64)
        rows, found = sorted_rows(self._ids, wanted)
        if not found.all():
            self._row(int(wanted.reshape(-1)[~found][0]))  # raises
        return self._points[rows]

    def home(self, fls_ids: IntArray) -> FloatArray:
        """(K, 3) the points FLSs ``fls_ids`` are assigned, cm."""
        return self._home[[self._row(int(fls_id)) for fls_id in fls_ids]]

    def _own(self, fls_id: int) -> None:
        if fls_id != self.fls_id:
            raise UnknownFlsError(f"this process senses for FLS {self.fls_id}, not {fls_id}")
