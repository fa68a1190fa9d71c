"""Conversions between the core's arrays and swazure_interfaces messages."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
from numpy.typing import NDArray
from swazure_interfaces.msg import (
    Measurements,
    PathOffer,
    PoseEstimate,
    PoseEstimates,
    RelativePose,
    TrackEstimate,
    WorldState,
)

from ..core.discovery import Estimate, Offer
from ..core.observe import NeighbourSets
from ..core.tracking import (
    CONSTANT_ACCELERATION,
    CONSTANT_VELOCITY,
    ENDED,
    TIMED_OUT,
    TRACKING,
    WAITING,
    MotionEstimate,
)
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


def offer_message(
    run_id: int, phase: int, round_: int, sender: int, offer: Offer, stamp: Time
) -> PathOffer:
    """One FLS's labels of one round as a PathOffer message."""
    message = PathOffer(
        run_id=run_id,
        phase=phase,
        round=round_,
        sender_id=sender,
        pending=offer.pending,
        finished=offer.finished,
    )
    message.header.stamp = stamp
    message.header.frame_id = f"fls_{sender}"
    # Array fields take numpy arrays of the right dtype without a Python loop.
    message.source_ids = offer.source_ids.astype(np.uint32)
    message.hops = offer.hops.astype(np.uint32)
    message.lengths = offer.lengths.astype(np.float64)
    message.vectors = offer.vectors.astype(np.float64).ravel()
    message.path_offsets = offer.path_offsets.astype(np.uint32)
    message.path_ids = offer.path_ids.astype(np.uint32)
    return message


def offer_from_message(message: PathOffer) -> Offer:
    """The labels of a PathOffer message."""
    return Offer(
        source_ids=np.asarray(message.source_ids, dtype=np.int64),
        hops=np.asarray(message.hops, dtype=np.int64),
        lengths=np.asarray(message.lengths, dtype=np.float64),
        vectors=np.asarray(message.vectors, dtype=np.float64).reshape(-1, 3),
        path_offsets=np.asarray(message.path_offsets, dtype=np.int64),
        path_ids=np.asarray(message.path_ids, dtype=np.int64),
        pending=message.pending,
        finished=message.finished,
    )


def estimate_message(source: int, found: Estimate) -> PoseEstimate:
    """One pair's estimate as a PoseEstimate message (NaN vector without a path)."""
    vector = found.vector.tolist()
    return PoseEstimate(
        source_id=source,
        target_id=found.target,
        status=found.status,
        reason=found.reason,
        path=list(found.path),
        hops=found.hops,
        radio_path=list(found.radio_path),
        vector=Vector3(x=vector[0], y=vector[1], z=vector[2]),
        path_length=found.length,
    )


def estimates_message(
    run_id: int, source: int, found: list[Estimate], stamp: Time
) -> PoseEstimates:
    """Every estimate of one source as a PoseEstimates message."""
    message = PoseEstimates(run_id=run_id, source_id=source)
    message.header.stamp = stamp
    message.header.frame_id = f"fls_{source}"
    message.estimates = [estimate_message(source, one) for one in found]
    for one in message.estimates:
        one.header = message.header
    return message


def estimate_from_message(message: PoseEstimate) -> Estimate:
    """The core's Estimate of a PoseEstimate message."""
    vector = message.vector
    return Estimate(
        target=int(message.target_id),
        status=int(message.status),
        reason=int(message.reason),
        path=tuple(int(fls) for fls in message.path),
        length=float(message.path_length),
        vector=np.array([vector.x, vector.y, vector.z]),
        radio_path=tuple(int(fls) for fls in message.radio_path),
    )


def vector3(values: FloatArray | None) -> Vector3:
    """A (3,) array as a Vector3; None as NaNs."""
    if values is None:
        return Vector3(x=float("nan"), y=float("nan"), z=float("nan"))
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def array3(vector: Vector3) -> FloatArray:
    """(3,) array of a Vector3."""
    return np.array([vector.x, vector.y, vector.z])


def to_seconds(stamp: Time) -> float:
    """Seconds of a builtin_interfaces Time, through whole nanoseconds as the clock counts."""
    return (stamp.sec * 1_000_000_000 + stamp.nanosec) / 1e9


def to_stamp(seconds: float) -> Time:
    """A builtin_interfaces Time of ``seconds`` (>= 0), rounded to whole nanoseconds."""
    nanoseconds = round(seconds * 1e9)
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


#: TrackEstimate.STATUS_* of the core's stream states.
TRACK_STATUS = {
    WAITING: TrackEstimate.STATUS_WAITING,
    TRACKING: TrackEstimate.STATUS_TRACKING,
    ENDED: TrackEstimate.STATUS_ENDED,
    TIMED_OUT: TrackEstimate.STATUS_TIMED_OUT,
}
#: TrackEstimate.MODEL_* (and TrackTarget's) of the core's filter models.
TRACK_MODELS = {
    CONSTANT_VELOCITY: TrackEstimate.MODEL_CONSTANT_VELOCITY,
    CONSTANT_ACCELERATION: TrackEstimate.MODEL_CONSTANT_ACCELERATION,
}


def track_estimate_message(
    source: int, target: int, model: str, estimate: MotionEstimate
) -> TrackEstimate:
    """A source's estimate of its target's motion as a TrackEstimate message."""
    kalman, filtered = estimate.kalman, estimate.filtered
    message = TrackEstimate(
        source_id=source,
        relay_id=estimate.relay,
        target_id=target,
        status=TRACK_STATUS[estimate.status],
        model=TRACK_MODELS[model],
        raw_position=vector3(estimate.raw),
        position=vector3(kalman and kalman.position),
        velocity=vector3(kalman and kalman.velocity),
        acceleration=vector3(kalman and kalman.acceleration),
        filtered_position=vector3(filtered and filtered.position),
        filtered_velocity=vector3(filtered and filtered.velocity),
        filtered_acceleration=vector3(filtered and filtered.acceleration),
        difference_velocity=vector3(estimate.difference_velocity),
        difference_acceleration=vector3(estimate.difference_acceleration),
        message=estimate.message,
    )
    message.header.stamp = to_stamp(estimate.time)
    message.header.frame_id = f"fls_{source}"
    if np.isfinite(estimate.sample_time):
        message.sample_stamp = to_stamp(estimate.sample_time)
    return message
