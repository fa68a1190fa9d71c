"""One process's copy of the world: the simulated camera and radio of the FLSs it hosts.

Every process of a swarm builds the same revision 0 from one
:class:`~.world.WorldSpec` and then follows the world node's revisions
(:meth:`WorldReplica.apply_positions`), so that each FLS senses the same
world wherever it runs. FLSs with a trajectory in ``motion`` fly it from
where the revision puts them, on the ROS clock (simulated time in a track run).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.motion import Motion
from ..core.observe import LocalView, Measurement, NearView, NeighbourSets
from ..core.relay import RelaySenses, moving_senses
from ..core.sensor import Sensor
from ..files.reading import config_dir
from .world import World

if TYPE_CHECKING:
    from ..camera.aruco import Camera


class WorldReplica:
    """The world as this process knows it; ``on_revision`` hooks run after each new revision."""

    def __init__(self, world: World, motion: Motion | None = None) -> None:
        self.world = world
        self.motion = motion or Motion()
        self.on_revision: list[Callable[[], None]] = []
        #: FLSs whose nodes this process saw leave the ROS graph (liveness).
        self.gone: set[int] = set()

    def measurement(self, fls_id: int, of: Sequence[int] | None = None) -> Measurement:
        """What FLS ``fls_id``'s camera measures in the current revision (of ``of`` only)."""
        return self.world.measurement(fls_id, of)

    def hop_measurements(
        self, fls_ids: Sequence[int], next_ids: Sequence[int]
    ) -> list[Measurement]:
        """What each FLS ``fls_ids[k]`` measures of ``next_ids[k]`` alone, in the current
        revision, read at once."""
        return self.world.hop_measurements(fls_ids, next_ids)

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbours in the current revision."""
        return self.world.neighbours(fls_id)

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours in the current revision."""
        return self.world.view(fls_id)

    def near_view(self, fls_id: int) -> NearView | None:
        """FLS ``fls_id``'s view with its blind and sweet neighbours only, and its whole view
        in this revision when asked for; None where the whole view is at hand."""
        world = self.world  # this revision's, whenever the whole view is asked for
        near = world.near_view(fls_id)
        return None if near is None else (near, partial(world.view, fls_id))

    @property
    def sensor(self) -> Sensor:
        """The sensor every FLS measures with."""
        return self.world.sensor

    @property
    def radius(self) -> float:
        """The FLSs' radius, cm."""
        return self.world.swarm.radius

    @property
    def ids(self) -> IntArray:
        """(N,) the swarm's FLS ids, sorted."""
        return self.world.ids

    @property
    def revision(self) -> int:
        """The world revision this process has."""
        return self.world.revision

    def positions(self, fls_ids: IntArray) -> FloatArray:
        """(K, 3) where FLSs ``fls_ids`` are in this process's revision, cm."""
        # take, not fancy indexing: 3x quicker for the millions of a round's path ids.
        return np.take(self.world.swarm.points, self.world.indices(fls_ids), axis=0)

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        return self.world.id_space

    @property
    def relay_senses(self) -> RelaySenses:
        """Relay choice and samples with every FLS where it flies at a time."""
        world = self.world
        return moving_senses(
            world.sensor, world.swarm.radius, world.ids, world.swarm.points, self.motion
        )

    def camera_image(
        self, fls_id: int, neighbour: int, frame: int
    ) -> tuple[Camera, NDArray[np.uint8]]:
        """What FLS ``fls_id``'s camera sees aimed at ``neighbour``'s marker: camera, image.

        The sensor's rendering camera, or the wide lens camera the published
        model describes; frame ``frame`` of a stream seeded by the pair, so
        that the same swarm shows the same frames.
        """
        from ..camera.aruco import Camera, MarkerPose, camera_seeing, full_image, render
        from ..files.sensors import load_camera

        world = self.world
        sensed = world.sensor.camera
        camera = (
            sensed
            if isinstance(sensed, Camera)
            else load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
        )
        offset = world.position(neighbour) - world.position(fls_id)
        tracking_mm = 10.0 * (float(np.linalg.norm(offset)) - 2.0 * world.swarm.radius)
        if tracking_mm <= camera.focal_length_mm:  # touching: the marker covers the lens
            return camera, np.zeros((camera.height, camera.width), np.uint8)
        seed = (world.sensor.camera_seed, fls_id, neighbour, frame)
        # The neighbour's own marker, as the sensor's measurements render it.
        seen = camera_seeing(camera, world.sensor.camera_markers, world.index(neighbour))
        return camera, full_image(
            seen, render(seen, MarkerPose(tracking_mm), np.random.default_rng(seed))
        )

    def apply(self, world: World) -> None:
        """Take a newer revision; whoever listens senses anew when next asked."""
        if world.revision <= self.world.revision:
            return
        self.world = world
        for hook in self.on_revision:
            hook()

    def apply_positions(self, revision: int, ids: IntArray, points: FloatArray) -> None:
        """Take the positions (N, 3), cm, of FLSs ``ids`` (N,) if ``revision`` is newer."""
        if revision > self.world.revision:
            self.apply(self.world.placed(ids, points, revision=revision))
