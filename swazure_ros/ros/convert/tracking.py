"""Tracking as messages: relay requests, samples, a source's estimates and an FLS's progress."""

from __future__ import annotations

from collections import Counter

import numpy as np
from geometry_msgs.msg import Vector3
from swazure_interfaces.msg import (
    TrackEstimate,
    TrackProgress,
    TrackRequest,
    TrackSample,
)

from ...core.arrays import FloatArray, IntArray
from ...core.estimators import TrackState
from ...core.frames import fls_frame, to_metres
from ...core.relay import RELAY_MESSAGES, RELAY_OK
from ...core.tracking import MotionEstimate
from ...protocol.tracking import (
    START_RELAY,
    STOP_RELAY,
    RelayRequest,
    Sample,
    TrackProgressReport,
    TrackReport,
)
from ..plumbing.names import (
    TRACK_MODEL_CODES,
    TRACK_STATE_CODES,
    TRACK_STATE_NAMES,
    node_name,
)
from ..security.guard import check, check_finite, check_ids
from .units import (
    array3,
    centimetres,
    nanoseconds_stamp,
    stamp_nanoseconds,
    to_seconds,
    to_stamp,
    vector3,
)


def track_estimate_message(report: TrackReport) -> TrackEstimate:
    """A source's estimate of its target's motion as a TrackEstimate message."""
    source, target, estimate = report.source, report.target, report.estimate
    kalman, filtered = estimate.kalman, estimate.filtered

    def metres(values: FloatArray | None) -> Vector3:
        return vector3(None if values is None else to_metres(values))

    message = TrackEstimate(
        source_id=source,
        relay_id=estimate.relay,
        target_id=target,
        status=TRACK_STATE_CODES[estimate.status],
        model=TRACK_MODEL_CODES[report.model],
        raw_position=metres(estimate.raw),
        position=metres(kalman.position if kalman is not None else None),
        velocity=metres(kalman.velocity if kalman is not None else None),
        acceleration=metres(kalman.acceleration if kalman is not None else None),
        filtered_position=metres(filtered.position if filtered is not None else None),
        filtered_velocity=metres(filtered.velocity if filtered is not None else None),
        filtered_acceleration=metres(filtered.acceleration if filtered is not None else None),
        difference_velocity=metres(estimate.difference_velocity),
        difference_acceleration=metres(estimate.difference_acceleration),
        message=estimate.message,
    )
    message.header.stamp = to_stamp(estimate.time)
    message.header.frame_id = fls_frame(source)
    if np.isfinite(estimate.sample_time):
        message.sample_stamp = to_stamp(estimate.sample_time)
    return message


#: The counters a TrackProgress message carries, as TrackProgressReport.traffic names them.
PROGRESS_COUNTERS = (
    "requests_sent",
    "requests_heard",
    "samples_sent",
    "samples_heard",
    "estimates_sent",
)


def track_progress_message(report: TrackProgressReport) -> TrackProgress:
    """One FLS's part in a track run as a TrackProgress message."""
    message = TrackProgress(fls_id=report.fls_id, relay_due=report.due)
    for name in PROGRESS_COUNTERS:
        setattr(message, name, report.traffic[name])
    message.header.stamp = nanoseconds_stamp(report.time)
    message.header.frame_id = fls_frame(report.fls_id)
    return message


def track_progress_from_message(message: TrackProgress, swarm: IntArray) -> TrackProgressReport:
    """The TrackProgressReport of a message; MessageError unless its FLS is the swarm's."""
    check_ids([message.fls_id], swarm, "track progress")
    traffic = Counter({name: int(getattr(message, name)) for name in PROGRESS_COUNTERS})
    return TrackProgressReport(
        int(message.fls_id), stamp_nanoseconds(message.header.stamp), traffic, message.relay_due
    )


def motion_estimate(message: TrackEstimate) -> MotionEstimate:
    """The core's estimate of a TrackEstimate message."""
    tracking = not np.isnan(message.position.x)

    def state(at: float, prefix: str) -> TrackState | None:
        if not tracking:
            return None
        return TrackState(
            at,
            centimetres(getattr(message, f"{prefix}position")),
            centimetres(getattr(message, f"{prefix}velocity")),
            centimetres(getattr(message, f"{prefix}acceleration")),
        )

    present = to_seconds(message.header.stamp)
    # A stamp of 0 is a real time on a simulated clock: no sample is a NaN raw position.
    sampled = not np.isnan(message.raw_position.x)
    sample_time = to_seconds(message.sample_stamp) if sampled else float("nan")
    return MotionEstimate(
        TRACK_STATE_NAMES[message.status],
        present,
        sample_time,
        centimetres(message.raw_position),
        state(present, ""),
        state(sample_time, "filtered_"),
        centimetres(message.difference_velocity),
        centimetres(message.difference_acceleration),
        message.message,
        int(message.relay_id),
    )


def relay_request_message(request: RelayRequest) -> TrackRequest:
    """A source's request to a relay as a TrackRequest message, stamped with its first frame."""
    message = TrackRequest(
        command=request.command,
        source_id=request.source,
        relay_id=request.relay,
        target_id=request.target,
    )
    message.header.stamp = nanoseconds_stamp(request.start)
    return message


def relay_request_from_message(message: TrackRequest, swarm: IntArray) -> RelayRequest:
    """The request of a TrackRequest message between FLSs of ``swarm`` (sorted ids)."""
    check(message.command in (START_RELAY, STOP_RELAY), f"unknown command {message.command}")
    check_ids([message.source_id, message.relay_id, message.target_id], swarm, "track request")
    return RelayRequest(
        int(message.command),
        int(message.source_id),
        int(message.relay_id),
        int(message.target_id),
        stamp_nanoseconds(message.header.stamp),
    )


def sample_message(sample: Sample) -> TrackSample:
    """A relayed sample as a TrackSample message, stamped when it was sensed."""
    message = TrackSample(
        source_id=sample.source,
        relay_id=sample.relay,
        target_id=sample.target,
        status=sample.status,
        position=vector3(sample.position),
    )
    message.header.stamp = nanoseconds_stamp(sample.sensed)
    message.header.frame_id = node_name(sample.source)
    return message


def sample_from_message(message: TrackSample, swarm: IntArray) -> Sample:
    """The sample of a TrackSample message between FLSs of ``swarm`` (sorted ids)."""
    check(message.status in RELAY_MESSAGES or message.status == RELAY_OK, "unknown status")
    check_ids([message.source_id, message.relay_id, message.target_id], swarm, "track sample")
    if message.status == RELAY_OK:
        check_finite(array3(message.position), "position")
    return Sample(
        int(message.source_id),
        int(message.relay_id),
        int(message.target_id),
        int(message.status),
        array3(message.position),
        stamp_nanoseconds(message.header.stamp),
    )
