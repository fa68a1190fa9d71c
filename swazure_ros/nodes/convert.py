"""Conversions between the core's arrays and swazure_interfaces messages."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
from numpy.typing import NDArray
from swazure_interfaces.msg import Measurements, RelativePose, WorldState

from ..core.observe import NeighbourSets
from ..sim.world import Measurement

FloatArray = NDArray[np.float64]


def measurements_message(fls_id: int, measurement: Measurement, stamp: Time) -> Measurements:
    """One FLS's camera measurements as a Measurements message."""
    message = Measurements(source_id=fls_id)
    message.header.stamp = stamp
    message.header.frame_id = f"fls_{fls_id}"
    for target, range_class, vector, tracking in zip(
        measurement.target_ids.tolist(),
        measurement.range_class.tolist(),
        measurement.vector.tolist(),
        measurement.tracking.tolist(),
    ):
        pose = RelativePose(
            source_id=fls_id,
            target_id=target,
            range_class=range_class,
            line_of_sight=True,
            vector=Vector3(x=vector[0], y=vector[1], z=vector[2]),
            tracking_distance=tracking,
        )
        pose.header = message.header
        message.poses.append(pose)
    return message


def neighbour_fields(sets: NeighbourSets) -> dict[str, list[int]]:
    """GetNeighbours response fields from neighbour sets of FLS ids."""
    return {
        "blind_ids": sets.blind.tolist(),
        "sweet_ids": sets.sweet.tolist(),
        "visible_sweet_ids": sets.visible_sweet.tolist(),
        "decaying_ids": sets.visible_decaying.tolist(),
    }


def world_message(
    revision: int, ids: NDArray[np.int64], points: FloatArray, stamp: Time
) -> WorldState:
    """Every FLS's position as a WorldState message."""
    message = WorldState(revision=revision, fls_ids=ids.tolist())
    message.header.stamp = stamp
    message.header.frame_id = "world"
    message.positions = [Point(x=p[0], y=p[1], z=p[2]) for p in points.tolist()]
    return message


def world_positions(message: WorldState) -> dict[int, FloatArray]:
    """FLS id -> (3,) position, cm, from a WorldState message."""
    return {
        int(fls_id): np.array([point.x, point.y, point.z])
        for fls_id, point in zip(message.fls_ids, message.positions)
    }
