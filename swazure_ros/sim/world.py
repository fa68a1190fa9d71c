"""The simulated world: where every FLS is, and what each one's camera and radio report.

A :class:`World` is ground truth for one swarm. Every process of a swarm builds
the same world from the same inputs (cloud, scale, beta or radius, sensor,
seed); positions then change only by :meth:`World.moved`, which returns the
next revision, so processes that apply the same moves agree. FLS ids are the
FLSs' row numbers in the point cloud, the ids of ``pairs.csv``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..core.clouds import Cloud, load_cloud
from ..core.errors import UnknownFlsError
from ..core.evaluate import Neighbourhood, moved_neighbourhood, neighbourhood
from ..core.geometry import Swarm, make_swarm
from ..core.observe import (
    LocalView,
    NeighbourSets,
    Observations,
    local_view,
    neighbour_sets,
    observations,
)
from ..core.sensor import Sensor, load_sensor

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


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
class World:
    """Ground truth of one swarm at one revision, with every FLS's observations."""

    cloud: Cloud
    sensor: Sensor
    home: Swarm  # the FLSs at their points of the cloud
    swarm: Swarm  # the FLSs where they are now
    revision: int
    hood: Neighbourhood
    seen: Observations
    # Revision 0's, kept because a heuristic returns every FLS home after each batch.
    home_hood: Neighbourhood
    home_seen: Observations

    @property
    def ids(self) -> IntArray:
        """(N,) FLS ids, in swarm order."""
        return self.swarm.cloud_index

    def index(self, fls_id: int) -> int:
        """Swarm index of FLS ``fls_id``; UnknownFlsError when the swarm has none."""
        position = int(np.searchsorted(self.ids, fls_id))
        if position >= len(self.ids) or self.ids[position] != fls_id:
            raise UnknownFlsError(
                f"no FLS {fls_id} in this swarm of {len(self.ids)} FLSs "
                f"(ids {self.ids[0]}..{self.ids[-1]})"
            )
        return position

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbour sets, as FLS ids."""
        sets = neighbour_sets(self.seen, self.index(fls_id))
        return NeighbourSets(*(self.ids[indices] for indices in vars(sets).values()))

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours, for path discovery."""
        return local_view(self.seen, self.ids, self.index(fls_id))

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        return int(self.ids[-1]) + 1

    def measurement(self, fls_id: int) -> Measurement:
        """What FLS ``fls_id``'s camera measures now."""
        rows = self.seen.rows(self.index(fls_id))
        measured = self.seen.measured_in(rows)
        return Measurement(
            self.ids[self.seen.other[rows][measured]],
            self.seen.range_class[rows][measured],
            self.seen.vector[rows][measured],
            self.seen.tracking[rows][measured],
        )

    def position(self, fls_id: int) -> FloatArray:
        """(3,) where FLS ``fls_id`` is now, cm."""
        return np.asarray(self.swarm.points[self.index(fls_id)])

    def moved(self, positions: dict[int, FloatArray], revision: int | None = None) -> World:
        """The world with FLSs moved to ``positions`` (id -> (3,) cm), at the next revision."""
        points = self.swarm.points.copy()
        for fls_id, position in positions.items():
            points[self.index(fls_id)] = position
        next_revision = self.revision + 1 if revision is None else revision
        if np.array_equal(points, self.home.points):
            return replace(
                self,
                swarm=self.home,
                revision=next_revision,
                hood=self.home_hood,
                seen=self.home_seen,
            )
        swarm = replace(self.swarm, points=points)
        # Only what moved is sensed anew: a heuristic's revision moves a few FLSs.
        moved = np.flatnonzero((points != self.swarm.points).any(axis=1))
        hood = moved_neighbourhood(self.hood, swarm, moved)
        return replace(
            self, swarm=swarm, revision=next_revision, hood=hood, seen=observations(hood)
        )


def make_world(
    cloud: Cloud,
    sensor: Sensor,
    beta: float | None = None,
    radius: float | None = None,
    seed: int = 0,
) -> World:
    """The world of ``cloud`` at revision 0: FLSs at their points, colliding ones removed."""
    swarm = make_swarm(cloud.points, beta=beta, radius=radius, seed=seed)
    hood = neighbourhood(swarm, sensor)
    seen = observations(hood)
    return World(cloud, sensor, swarm, swarm, 0, hood, seen, hood, seen)


@dataclass(frozen=True)
class WorldSpec:
    """Everything that determines a world: what every process of a swarm is given."""

    cloud: str
    scale: float | None = None
    beta: float | None = None
    radius: float | None = None
    sensor_file: str | None = None
    accurate: bool = False
    seed: int = 0

    def build(self) -> World:
        """Load the cloud and sensor and make the world at revision 0."""
        sensor = load_sensor(Path(self.sensor_file) if self.sensor_file else None)
        if self.accurate:
            sensor = sensor.error_free()
        cloud = load_cloud(self.cloud, self.scale)
        return make_world(cloud, sensor, beta=self.beta, radius=self.radius, seed=self.seed)
