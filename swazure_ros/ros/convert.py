"""Conversions between the core's and the protocol's data and swazure_interfaces messages.

Each message type converts here, and only here, both ways where both are needed.
"""

from __future__ import annotations

import array
from collections import Counter
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseWithCovariance, Vector3
from numpy.typing import NDArray
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import ColorRGBA, Header
from swazure_interfaces.msg import (
    Detections,
    DiscoveryControl,
    MarkerDetection,
    Measurements,
    MoveCommand,
    MoveCommands,
    PathEstimate,
    PathOffer,
    PathWalk,
    PoseEstimate,
    PoseEstimates,
    RelativePose,
    RoundAck,
    TrackEstimate,
    TrackProgress,
    TrackRequest,
    TrackSample,
    WorldState,
)
from visualization_msgs.msg import Marker, MarkerArray

from ..core.evaluate import REASON_NAMES, STATUS_NAMES
from ..core.fit import PATH
from ..core.frames import CM_PER_METRE, METRES_PER_CM, fls_frame, to_centimetres, to_metres
from ..core.observe import Measurement, NeighbourSets
from ..core.sensor import DECAYING, SWEET, Sensor
from ..core.tracking import RELAY_MESSAGES, RELAY_OK, MotionEstimate, TrackState
from ..protocol.discovery import (
    END,
    PHASES,
    ROUND,
    START,
    SWEET_ALL,
    Broadcast,
    Control,
    Estimate,
    Offer,
    Report,
)
from ..protocol.moves import ARRIVED, FAILED, WALKING, Move, Walk
from ..protocol.radio import Ack
from ..protocol.readings import Readings
from ..protocol.tracking import (
    START_RELAY,
    STOP_RELAY,
    RelayRequest,
    Sample,
    TrackProgressReport,
    TrackReport,
)
from .guard import check, check_finite, check_ids, check_size
from .names import (
    ESTIMATOR_CODES,
    ESTIMATOR_NAMES,
    POLICY_CODES,
    POLICY_NAMES,
    TRACK_MODEL_CODES,
    TRACK_STATE_CODES,
    TRACK_STATE_NAMES,
    node_name,
)

if TYPE_CHECKING:
    from ..core.camera import Camera
    from ..view.scene import Scene

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def measurements_message(
    fls_id: int, measurement: Measurement, stamp: Time, radio_distance: FloatArray | None = None
) -> Measurements:
    """One FLS's camera measurements as a Measurements message, in metres in the FLS's frame.

    ``radio_distance`` (K,), cm: each measured pair's distance by radio
    ranging (NaN where not given).
    """
    message = Measurements(source_id=fls_id)
    message.header.stamp = stamp
    message.header.frame_id = fls_frame(fls_id)
    count = len(measurement.target_ids)
    radio = np.full(count, np.nan) if radio_distance is None else radio_distance
    for target, range_class, vector, tracking, ranged in zip(
        measurement.target_ids.tolist(),
        measurement.range_class.tolist(),
        to_metres(measurement.vector).tolist(),
        to_metres(measurement.tracking).tolist(),
        to_metres(radio).tolist(),
        strict=True,
    ):
        pose = RelativePose(
            source_id=fls_id,
            target_id=target,
            range_class=range_class,
            line_of_sight=True,
            vector=Vector3(x=vector[0], y=vector[1], z=vector[2]),
            tracking_distance=tracking,
            radio_distance=ranged,
        )
        pose.header = message.header
        message.poses.append(pose)
    return message


def readings_from_message(message: Measurements, swarm: IntArray) -> Readings:
    """The camera readings (cm) of a Measurements message from an FLS of ``swarm`` (sorted ids).

    MessageError unless every pose is the source's, of an FLS of the swarm
    once, in sweet or decaying range, with a finite vector and radio
    distance.
    """
    poses = message.poses
    check_size(poses, len(swarm), "poses")
    source = int(message.source_id)
    check(all(pose.source_id == source for pose in poses), "a pose of another FLS")
    other = check_ids([source] + [pose.target_id for pose in poses], swarm, "poses")[1:]
    check(len(np.unique(other)) == len(other), "an FLS measured twice")
    check(source not in other, "an FLS measures itself")
    range_class = np.array([pose.range_class for pose in poses], dtype=np.int8)
    check(bool(np.isin(range_class, (SWEET, DECAYING)).all()), "a reading out of camera range")
    numbers = [(p.vector.x, p.vector.y, p.vector.z, p.radio_distance) for p in poses]
    values = to_centimetres(check_finite(numbers, "poses").reshape(-1, 4))
    order = np.argsort(other, kind="stable")
    return Readings(
        source, other[order], range_class[order], values[order, 3], values[order, :3].copy()
    )


#: Readings a Detections message may hold: a camera reads a few dozen markers at most.
MAX_DETECTIONS = 4096


def detections_message(
    fls_id: int,
    measurement: Measurement,
    markers: IntArray,
    sensor: Sensor,
    stamp: Time,
    revision: int = 0,
) -> Detections:
    """What FLS ``fls_id``'s simulated camera reads in world ``revision``, as a camera would.

    ``markers`` (K,) are the markers of the measured FLSs; each pose is centre
    to centre in metres in the FLS's frame, its position variance the
    sensor's length error at that distance, squared, on each axis; its
    rotation unknown (variance -1).
    """
    message = Detections(revision=revision)
    message.header.stamp = stamp
    message.header.frame_id = fls_frame(fls_id)
    error = np.abs(sensor.relative_error(measurement.tracking) * measurement.tracking)
    for marker, vector, sigma in zip(
        markers.tolist(),
        to_metres(measurement.vector).tolist(),
        to_metres(error).tolist(),
        strict=True,
    ):
        pose = PoseWithCovariance()
        pose.pose.position = Point(x=vector[0], y=vector[1], z=vector[2])
        pose.pose.orientation.w = 1.0
        covariance = np.zeros((6, 6))
        covariance[[0, 1, 2], [0, 1, 2]] = sigma * sigma
        covariance[[3, 4, 5], [3, 4, 5]] = -1.0
        pose.covariance = covariance.ravel().tolist()
        message.detections.append(MarkerDetection(marker_id=marker, pose=pose))
    return message


def detections_from_message(message: Detections, fls_id: int) -> tuple[IntArray, FloatArray]:
    """Markers (K,) and centre-to-centre vectors (K, 3), cm, of FLS ``fls_id``'s detections.

    MessageError unless the poses are in the FLS's own frame (a detector's
    optical-frame poses must be moved there by the camera's mount first),
    finite and at most MAX_DETECTIONS.
    """
    check(
        message.header.frame_id == fls_frame(fls_id),
        f"detections in frame {message.header.frame_id[:40]!r}, not {fls_frame(fls_id)}",
    )
    check_size(message.detections, MAX_DETECTIONS, "detections")
    markers = np.array([one.marker_id for one in message.detections], dtype=np.int64)
    positions = [one.pose.pose.position for one in message.detections]
    vectors = np.array([[p.x, p.y, p.z] for p in positions], dtype=np.float64).reshape(-1, 3)
    check_finite(vectors, "detection positions")
    return markers, to_centimetres(vectors)


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
    message = WorldState(revision=revision)
    message.fls_ids = array.array("I", np.asarray(ids, dtype=np.uint32).tobytes())
    message.positions = array.array("d", np.asarray(points, dtype=np.float64).tobytes())
    message.header.stamp = stamp
    message.header.frame_id = "world"
    return message


def world_positions(
    message: WorldState, swarm: IntArray, reach: float
) -> tuple[NDArray[np.int64], FloatArray]:
    """FLS ids (N,) and their positions (N, 3), cm, from a WorldState message.

    MessageError unless every id is one of ``swarm``'s (sorted ids), once, and
    every position is finite and within ``reach`` cm of the origin.
    """
    check_size(message.fls_ids, len(swarm), "fls_ids")
    check(len(message.positions) == 3 * len(message.fls_ids), "not 3 positions per FLS")
    ids = check_ids(np.frombuffer(message.fls_ids, dtype=np.uint32), swarm, "fls_ids")
    check(len(np.unique(ids)) == len(ids), "an FLS is listed twice")
    points = check_finite(np.frombuffer(message.positions, dtype=np.float64), "positions")
    check(bool(np.all(np.abs(points) <= reach)), f"a position beyond {reach:g} cm")
    return ids, points.reshape(-1, 3).copy()


def offer_message(sent: Broadcast, stamp: Time) -> PathOffer:
    """One FLS's labels of one round as a PathOffer message."""
    offer, sender = sent.offer, sent.sender
    message = PathOffer(
        run_id=sent.run_id,
        phase=sent.phase,
        round=sent.round,
        sender_id=sender,
        pending=offer.pending,
        finished=offer.finished,
    )
    message.header.stamp = stamp
    message.header.frame_id = node_name(sender)
    # Array fields take numpy arrays of the right dtype without a Python loop.
    message.source_ids = offer.source_ids.astype(np.uint32)
    message.hops = offer.hops.astype(np.uint32)
    message.lengths = offer.lengths.astype(np.float64)
    message.errors = offer.errors.astype(np.float64)
    message.vectors = offer.vectors.astype(np.float64).ravel()
    message.path_offsets = offer.path_offsets.astype(np.uint32)
    message.path_ids = offer.path_ids.astype(np.uint32)
    if offer.unbiased is not None and offer.covariances is not None:
        message.unbiased_vectors = offer.unbiased.astype(np.float64).ravel()
        message.covariances = offer.covariances.astype(np.float64).ravel()
    message.reading_ids = offer.reading_ids.astype(np.uint32)
    message.reading_vectors = offer.reading_vectors.astype(np.float64).ravel()
    return message


def offer_from_message(message: PathOffer, swarm: IntArray) -> Offer:
    """The labels of a PathOffer message from an FLS of ``swarm`` (sorted ids).

    MessageError unless its arrays agree in length, every id is in the swarm,
    every path runs from its label's source to the sender with ``hops`` hops,
    and costs are finite and not negative (vectors may be NaN only in the
    S_all phase, whose hops need no camera reading).
    """
    check(message.phase in PHASES, f"unknown phase {message.phase}")
    count = len(message.source_ids)
    check_size(message.source_ids, len(swarm), "source_ids")
    check(
        len(message.hops) == count == len(message.lengths) == len(message.errors),
        "source_ids, hops, lengths and errors differ in length",
    )
    check(len(message.vectors) == 3 * count, "not 3 vector values per label")
    fits = len(message.unbiased_vectors) > 0 or len(message.covariances) > 0
    check_size(message.reading_ids, len(swarm), "reading_ids")
    check(len(message.reading_vectors) == 3 * len(message.reading_ids), "not 3 values a reading")
    reading_ids = check_ids(message.reading_ids, swarm, "reading_ids")
    check(len(np.unique(reading_ids)) == len(reading_ids), "an FLS read twice")
    reading_vectors = check_finite(message.reading_vectors, "reading_vectors").reshape(-1, 3)
    check(
        not fits
        or (len(message.unbiased_vectors) == 3 * count and len(message.covariances) == 9 * count),
        "not 3 unbiased vector and 9 covariance values per label",
    )
    check(len(message.path_offsets) == count + 1, "not one more path offset than labels")
    sources = np.asarray(message.source_ids, dtype=np.int64)
    # A sender offers its labels in source order, one a source (PathSearch.offer).
    check(bool(np.all(np.diff(sources) > 0)), "sources not in increasing order, once each")
    hops = np.asarray(message.hops, dtype=np.int64)
    lengths = check_finite(message.lengths, "lengths")
    errors = check_finite(message.errors, "errors")
    check(bool(np.all(lengths >= 0) and np.all(errors >= 0)), "a negative cost")
    vectors = check_finite(message.vectors, "vectors", allow_nan=message.phase == SWEET_ALL)
    offsets = np.asarray(message.path_offsets, dtype=np.int64)
    check_size(message.path_ids, count * len(swarm), "path_ids")
    check(
        offsets[0] == 0 and offsets[-1] == len(message.path_ids),
        "path offsets do not span path_ids",
    )
    check(bool(np.all(np.diff(offsets) == hops + 1)), "a path is not hops + 1 FLSs long")
    path_ids = np.asarray(message.path_ids, dtype=np.int64)
    # One look-up for every id: the sender's, and those of the paths (sources included).
    check_ids(np.append(path_ids, message.sender_id), swarm, "offer")
    if count:
        starts, ends = path_ids[offsets[:-1]], path_ids[offsets[1:] - 1]
        check(bool(np.all(starts == sources)), "a path does not start at its source")
        check(bool(np.all(ends == message.sender_id)), "a path does not end at the sender")
    return Offer(
        source_ids=sources,
        hops=hops,
        lengths=lengths,
        errors=errors,
        vectors=vectors.reshape(-1, 3),
        path_offsets=offsets,
        path_ids=path_ids,
        pending=message.pending,
        finished=message.finished,
        unbiased=_fit_sums(message, "unbiased_vectors", (-1, 3)) if fits else None,
        covariances=_fit_sums(message, "covariances", (-1, 3, 3)) if fits else None,
        reading_ids=reading_ids,
        reading_vectors=reading_vectors,
    )


def _fit_sums(message: PathOffer, name: str, shape: tuple[int, ...]) -> FloatArray:
    """A fitting offer's sums of field ``name``, shaped (NaN only where vectors may be)."""
    values = check_finite(getattr(message, name), name, allow_nan=message.phase == SWEET_ALL)
    return values.reshape(shape)


def estimate_message(found: Estimate) -> PathEstimate:
    """One pair's estimate as the protocol reports it (cm; NaN vector without a path)."""
    return PathEstimate(**_estimate_fields(found, lambda centimetres: centimetres))


def pose_estimate_message(source: int, found: Estimate, stamp: Time) -> PoseEstimate:
    """One pair's estimate for people and other software: metres, in ``fls_<source>``."""
    message = PoseEstimate(source_id=source, **_estimate_fields(found, to_metres))
    message.header.stamp = stamp
    message.header.frame_id = fls_frame(source)
    return message


def _estimate_fields(found: Estimate, unit: Callable[[Any], Any]) -> dict[str, Any]:
    """The fields PathEstimate and PoseEstimate share, lengths converted by ``unit``."""
    vector = unit(found.vector).tolist()
    covariance = np.full(9, np.nan) if found.covariance is None else found.covariance.ravel()
    return {
        "estimator": ESTIMATOR_CODES[found.estimator],
        "covariance": unit(unit(covariance)),
        "target_id": found.target,
        "status": found.status,
        "reason": found.reason,
        "path": list(found.path),
        "hops": found.hops,
        "radio_path": list(found.radio_path),
        "vector": Vector3(x=vector[0], y=vector[1], z=vector[2]),
        "path_length": unit(found.length),
        "predicted_error": unit(found.predicted_error),
    }


def estimates_message(report: Report, stamp: Time) -> PoseEstimates:
    """Every estimate of one source as a PoseEstimates message."""
    source, found = report.source, report.estimates
    message = PoseEstimates(run_id=report.run_id, source_id=source)
    message.header.stamp = stamp
    message.header.frame_id = node_name(source)
    message.estimates = [estimate_message(one) for one in found]
    return message


def estimates_from_message(message: PoseEstimates, swarm: IntArray) -> list[Estimate]:
    """The core's Estimates of a source's report, checked against ``swarm`` (sorted ids).

    MessageError unless the source and every target and path FLS are the
    swarm's, codes are known, paths are no longer than the swarm and numbers
    are finite or NaN (no path).
    """
    estimates = message.estimates
    check_size(estimates, len(swarm), "estimates")
    ids = [message.source_id]
    for one in estimates:
        check(
            len(one.path) <= len(swarm) and len(one.radio_path) <= len(swarm),
            "a path longer than the swarm",
        )
        ids.append(one.target_id)
        ids.extend(one.path)
        ids.extend(one.radio_path)
    check_ids(ids, swarm, "estimates")
    check(
        all(
            one.status < len(STATUS_NAMES) and one.reason < len(REASON_NAMES) for one in estimates
        ),
        "unknown status or reason",
    )
    numbers = [(one.vector.x, one.vector.y, one.vector.z, one.path_length) for one in estimates]
    check_finite(numbers, "vector", allow_nan=True)
    check(all(one.estimator in ESTIMATOR_NAMES for one in estimates), "unknown estimator")
    check_finite([list(one.covariance) for one in estimates], "covariance", allow_nan=True)
    return [estimate_from_message(one) for one in estimates]


def estimate_from_message(message: PathEstimate) -> Estimate:
    """The core's Estimate of a reported PathEstimate (unchecked: see estimates_from_message)."""
    return _estimate(message, 1.0)


def pose_estimate_from_message(message: PoseEstimate) -> Estimate:
    """The core's Estimate (cm) of a PoseEstimate (m), for people: not the protocol's bits."""
    return _estimate(message, CM_PER_METRE)


def _estimate(message: PathEstimate | PoseEstimate, cm_per_unit: float) -> Estimate:
    """An Estimate of either message; lengths times ``cm_per_unit`` (1: already in cm)."""
    vector = message.vector
    covariance = np.asarray(message.covariance, dtype=np.float64).reshape(3, 3)
    fitted = np.isfinite(covariance).all()
    return Estimate(
        target=int(message.target_id),
        status=int(message.status),
        reason=int(message.reason),
        path=tuple(int(fls) for fls in message.path),
        length=float(message.path_length) * cm_per_unit,
        vector=np.array([vector.x, vector.y, vector.z]) * cm_per_unit,
        radio_path=tuple(int(fls) for fls in message.radio_path),
        predicted_error=float(message.predicted_error) * cm_per_unit,
        estimator=ESTIMATOR_NAMES.get(message.estimator, PATH),
        covariance=covariance * cm_per_unit**2 if fitted else None,
    )


def vector3(values: FloatArray | None) -> Vector3:
    """A (3,) array as a Vector3; None as NaNs."""
    if values is None:
        return Vector3(x=float("nan"), y=float("nan"), z=float("nan"))
    return Vector3(x=float(values[0]), y=float(values[1]), z=float(values[2]))


def array3(vector: Vector3) -> FloatArray:
    """(3,) array of a Vector3."""
    return np.array([vector.x, vector.y, vector.z])


def centimetres(vector: Vector3) -> FloatArray:
    """(3,) array, cm, of a Vector3 in metres."""
    return to_centimetres(array3(vector))


def to_seconds(stamp: Time) -> float:
    """Seconds of a builtin_interfaces Time, through whole nanoseconds as the clock counts."""
    return stamp_nanoseconds(stamp) / 1e9


def to_stamp(seconds: float) -> Time:
    """A builtin_interfaces Time of ``seconds`` (>= 0), rounded to whole nanoseconds."""
    return nanoseconds_stamp(round(seconds * 1e9))


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
        position=metres(kalman and kalman.position),
        velocity=metres(kalman and kalman.velocity),
        acceleration=metres(kalman and kalman.acceleration),
        filtered_position=metres(filtered and filtered.position),
        filtered_velocity=metres(filtered and filtered.velocity),
        filtered_acceleration=metres(filtered and filtered.acceleration),
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


def control_message(control: Control, stamp: Time) -> DiscoveryControl:
    """A tick of the round clock as a DiscoveryControl message."""
    message = DiscoveryControl(
        run_id=control.run_id,
        command=control.command,
        phase=control.phase,
        policy=POLICY_CODES[control.policy],
        round=control.round,
        expected=control.expected,
        source_ids=list(control.source_ids),
        target_ids=list(control.target_ids),
        finished_ids=list(control.finished_ids),
        departed_ids=list(control.departed_ids),
        estimator=ESTIMATOR_CODES[control.estimator],
    )
    message.header.stamp = stamp
    return message


def control_from_message(message: DiscoveryControl, swarm: IntArray) -> Control:
    """The round clock's tick of a DiscoveryControl message to the FLSs of ``swarm`` (sorted ids).

    MessageError for an unknown command, phase or policy, an id not in the swarm,
    or targets that do not pair with the sources.
    """
    check(message.command in (START, ROUND, END), f"unknown command {message.command}")
    check(message.phase in PHASES, f"unknown phase {message.phase}")
    check(message.policy in POLICY_NAMES, f"unknown policy {message.policy}")
    check(message.estimator in ESTIMATOR_NAMES, f"unknown estimator {message.estimator}")
    check(message.expected <= len(swarm), f"expects {message.expected} FLSs, more than the swarm")
    lists = {}
    for name in ("source_ids", "target_ids", "finished_ids", "departed_ids"):
        values = getattr(message, name)
        check_size(values, len(swarm), name)
        lists[name] = tuple(check_ids(values, swarm, name).tolist())
    check(
        not lists["target_ids"] or len(lists["target_ids"]) == len(lists["source_ids"]),
        "target_ids do not pair with source_ids",
    )
    return Control(
        run_id=int(message.run_id),
        command=int(message.command),
        phase=int(message.phase),
        policy=POLICY_NAMES[message.policy],
        round=int(message.round),
        expected=int(message.expected),
        estimator=ESTIMATOR_NAMES[message.estimator],
        **lists,
    )


def ack_message(ack: Ack, host: str, stamp: Time) -> RoundAck:
    """A process's acknowledgement of a round as a RoundAck message."""
    message = RoundAck(
        run_id=ack.run_id,
        phase=ack.phase,
        round=ack.round,
        heard=ack.heard,
        repairs=ack.repairs,
        lost=ack.lost,
    )
    message.host = host
    message.header.stamp = stamp
    return message


def moves_message(moves: Sequence[Move], stamp: Time) -> MoveCommands:
    """Moves made together (one group) as one MoveCommands message."""
    commands = []
    for move in moves:
        command = MoveCommand(
            fls_id=move.fls_id,
            kind=move.kind,
            source_id=move.source_id,
            target_id=move.target_id,
        )
        if move.displacement is not None:
            command.displacement = vector3(move.displacement)
        commands.append(command)
    message = MoveCommands(commands=commands)
    message.header.stamp = stamp
    return message


def moves_from_message(
    message: MoveCommands, swarm: IntArray, reach: float
) -> tuple[IntArray, IntArray, FloatArray]:
    """(FLS ids (K,), kinds (K,), displacements (K, 3), cm) of a MoveCommands message.

    MessageError unless every FLS is one of ``swarm``'s (sorted ids), once, every
    kind is known and every displacement is finite and within ``reach`` cm:
    the batch is made together, so it is taken whole or not at all.
    """
    commands = message.commands
    check_size(commands, len(swarm), "commands")
    ids = check_ids([command.fls_id for command in commands], swarm, "commands")
    check(len(np.unique(ids)) == len(ids), "an FLS is commanded twice")
    kinds = np.array([command.kind for command in commands], dtype=np.int64)
    known = (MoveCommand.KIND_STEP_ASIDE, MoveCommand.KIND_PROBE, MoveCommand.KIND_RETURN)
    check(bool(np.isin(kinds, known).all()), "unknown kind")
    displacement = check_finite(
        [array3(command.displacement) for command in commands], "displacement"
    ).reshape(-1, 3)
    check(bool(np.all(np.abs(displacement) <= reach)), f"a displacement beyond {reach:g} cm")
    return ids, kinds, displacement


def walk_message(walk: Walk, stamp: Time) -> PathWalk:
    """A path walk as a PathWalk message."""
    message = PathWalk(
        run_id=walk.run_id,
        revision=walk.revision,
        source_id=walk.source_id,
        target_id=walk.target_id,
        path=list(walk.path),
        hop=walk.hop,
        state=walk.state,
        vector=vector3(walk.vector),
    )
    message.header.stamp = stamp
    return message


def walk_from_message(message: PathWalk, swarm: IntArray) -> Walk:
    """The path walk of a PathWalk message along FLSs of ``swarm`` (sorted ids).

    MessageError unless the path has two or more distinct FLSs of the swarm, the
    hop is on it, the state is known and a walk under way sums finite vectors.
    """
    check(message.state in (WALKING, ARRIVED, FAILED), f"unknown state {message.state}")
    check(2 <= len(message.path) <= len(swarm), "a path of fewer than 2 or more than N FLSs")
    path = check_ids(message.path, swarm, "path")
    check(len(np.unique(path)) == len(path), "a path visits an FLS twice")
    check(message.hop < len(path), f"hop {message.hop} is past the path's end")
    vector = array3(message.vector)
    if message.state != FAILED:
        check_finite(vector, "vector")
    return Walk(
        run_id=int(message.run_id),
        revision=int(message.revision),
        path=tuple(path.tolist()),
        hop=int(message.hop),
        state=int(message.state),
        vector=vector,
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


def nanoseconds_stamp(nanoseconds: int) -> Time:
    """A builtin_interfaces Time of whole ``nanoseconds`` (>= 0)."""
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def stamp_nanoseconds(stamp: Time) -> int:
    """Whole nanoseconds of a builtin_interfaces Time."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def image_message(image: NDArray[np.uint8], stamp: Time, frame_id: str) -> Image:
    """A grey (H, W) image as sensor_msgs/Image, mono8."""
    rows, columns = image.shape
    return Image(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=rows,
        width=columns,
        encoding="mono8",
        is_bigendian=0,
        step=columns,
        data=np.ascontiguousarray(image).tobytes(),
    )


def camera_info_message(camera: Camera, stamp: Time, frame_id: str) -> CameraInfo:
    """The camera's intrinsics as sensor_msgs/CameraInfo (no distortion: the renderer has none)."""
    matrix = camera.matrix
    projection = np.hstack([matrix, np.zeros((3, 1))])
    return CameraInfo(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=camera.height,
        width=camera.width,
        distortion_model="plumb_bob",
        d=[0.0] * 5,
        k=matrix.ravel().tolist(),
        r=np.eye(3).ravel().tolist(),
        p=projection.ravel().tolist(),
    )


def _colour(rgba: Sequence[float]) -> ColorRGBA:
    red, green, blue, alpha = (float(value) for value in rgba)
    return ColorRGBA(r=red, g=green, b=blue, a=alpha)


def _point(xyz: Sequence[float]) -> Point:
    x, y, z = (float(value) * METRES_PER_CM for value in xyz)
    return Point(x=x, y=y, z=z)


def scene_markers(scene: Scene, stamp: Time) -> MarkerArray:
    """The scene as RViz markers (metres): FLSs as one sphere list, paths, moves as arrows.

    The first marker deletes what an earlier scene drew.
    """
    # Here, not at import: the scene is the viewer's, which an FLS alone never runs.
    from ..view.scene import MOVE_COLOUR, SCENE_FRAME

    header = Header(stamp=stamp, frame_id=SCENE_FRAME)
    markers = [Marker(header=header, action=Marker.DELETEALL)]
    diameter = 2 * scene.radius * METRES_PER_CM
    flss = Marker(header=header, ns="flss", id=0, type=Marker.SPHERE_LIST, action=Marker.ADD)
    flss.pose.orientation.w = 1.0
    flss.scale = Vector3(x=diameter, y=diameter, z=diameter)
    flss.points = [_point(point) for point in scene.points]
    flss.colors = [_colour(colour) for colour in scene.colours]
    markers.append(flss)
    for index, path in enumerate(scene.paths):
        line = Marker(header=header, ns="paths", id=index, type=Marker.LINE_STRIP)
        line.pose.orientation.w = 1.0
        line.scale.x = diameter / 4
        line.color = _colour(path.colour)
        line.points = [_point(point) for point in path.points]
        line.text = path.label
        markers.append(line)
    for index, (start, end) in enumerate(scene.moves):
        arrow = Marker(header=header, ns="moves", id=index, type=Marker.ARROW)
        arrow.pose.orientation.w = 1.0
        arrow.scale = Vector3(x=diameter / 6, y=diameter / 3, z=diameter / 3)
        arrow.color = _colour(MOVE_COLOUR)
        arrow.points = [_point(start), _point(end)]
        markers.append(arrow)
    return MarkerArray(markers=markers)
