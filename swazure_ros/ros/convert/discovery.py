"""Discovery and moves as messages: controls, offers, estimates, acks, moves, path walks."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3
from swazure_interfaces.msg import (
    DiscoveryControl,
    Heartbeat,
    MoveCommand,
    MoveCommands,
    PathWalk,
    PoseEstimate,
    PoseEstimates,
    RoundAck,
)

from ...core.arrays import FloatArray, IntArray
from ...core.evaluation import REASON_NAMES, STATUS_NAMES
from ...core.fit import PATH, SWARM_ESTIMATORS
from ...core.frames import CM_PER_METRE, fls_frame, to_metres
from ...protocol.discovery.estimate import Estimate, Estimates
from ...protocol.discovery.messages import (
    END,
    FIT,
    PHASES,
    ROUND,
    SAMPLES,
    STAGE_NAMES,
    STALLED,
    START,
    Control,
    FitStep,
    Report,
)
from ...protocol.moves import ARRIVED, FAILED, WALKING, Move, Walk
from ...protocol.pulse import Alive
from ...protocol.radio import Ack, Sent
from ..plumbing.names import (
    ESTIMATOR_CODES,
    ESTIMATOR_NAMES,
    POLICY_CODES,
    POLICY_NAMES,
    node_name,
)
from ..security.guard import check, check_finite, check_ids, check_size
from ..security.records import Fields
from .units import array3, message_of, packed, vector3

#: Every phase a run may have: discovery's, then the swarm's fit.
RUN_PHASES = (*PHASES, FIT)
#: Values of the FIT phase's vectors and sums one message may carry: per fit (two at
#: most), a position and the covariance's samples, 3 each (core.swarm_fit's 64, with room).
FIT_VALUES = 2 * 3 * (1 + 1024)


def pose_estimate_message(source: int, found: Estimate, stamp: Time) -> PoseEstimate:
    """One pair's estimate for people and other software: metres, in ``fls_<source>``."""
    vector = to_metres(found.vector).tolist()
    covariance = np.full(9, np.nan) if found.covariance is None else found.covariance.ravel()
    message = PoseEstimate(
        source_id=source,
        target_id=found.target,
        status=found.status,
        reason=found.reason,
        path=list(found.path),
        hops=found.hops,
        radio_path=list(found.radio_path),
        vector=Vector3(x=vector[0], y=vector[1], z=vector[2]),
        path_length=to_metres(found.length),
        predicted_error=to_metres(found.predicted_error),
        estimator=ESTIMATOR_CODES[found.estimator],
        covariance=to_metres(to_metres(covariance)),
    )
    message.header.stamp = stamp
    message.header.frame_id = fls_frame(source)
    return message


def estimates_fields(report: Report, stamp: Time) -> Fields:
    """Every estimate of one source: a PoseEstimates message's fields by name, one array entry
    per target (:mod:`..security.records`)."""
    source, found = report.source, Estimates.of(report.estimates)
    fields: dict[str, Any] = {
        "header.stamp.sec": stamp.sec,
        "header.stamp.nanosec": stamp.nanosec,
        "header.frame_id": node_name(source),
        "run_id": report.run_id,
        "source_id": source,
        "target_ids": found.targets,
        "statuses": found.status,
        "reasons": found.reason,
        "estimators": _ESTIMATOR_WIRE[found.estimator],
        "path_offsets": found.path_offsets,
        "path_ids": found.path_ids,
        "radio_path_offsets": found.radio_offsets,
        "radio_path_ids": found.radio_ids,
        "vectors": found.vector,
        "path_lengths": found.length,
        "predicted_errors": found.predicted_error,
    }
    # A path's estimates have no covariance: none is sent (nine NaNs were 72 of about 155 B each).
    if not np.isnan(found.covariance).all():
        fields["covariances"] = found.covariance
    return fields


def estimates_message(report: Report, stamp: Time) -> PoseEstimates:
    """Every estimate of one source as a PoseEstimates message (:func:`estimates_fields`)."""
    message: PoseEstimates = message_of(PoseEstimates, estimates_fields(report, stamp))
    return message


#: core.fit.SWARM_ESTIMATORS index -> DiscoveryControl.ESTIMATOR_*, and back.
_ESTIMATOR_WIRE = np.array([ESTIMATOR_CODES[name] for name in SWARM_ESTIMATORS], dtype=np.uint8)
_ESTIMATOR_INDEX = np.full(256, -1, dtype=np.int8)
_ESTIMATOR_INDEX[_ESTIMATOR_WIRE] = np.arange(len(SWARM_ESTIMATORS))


def estimates_from_message(message: PoseEstimates, swarm: IntArray) -> Estimates:
    """The core's Estimates of a source's report, checked against ``swarm`` (sorted ids).

    MessageError unless the arrays agree in length, the source and every
    target and path FLS are the swarm's, codes are known, paths are no
    longer than the swarm and numbers are finite or NaN (no path).
    """
    count = len(message.target_ids)
    check_size(message.target_ids, len(swarm), "estimates")
    check(
        len(message.statuses) == len(message.reasons) == len(message.estimators) == count
        and len(message.path_lengths) == len(message.predicted_errors) == count,
        "target_ids, statuses, reasons, estimators, path_lengths and predicted_errors "
        "differ in length",
    )
    check(len(message.vectors) == 3 * count, "not 3 vector values per estimate")
    check(
        len(message.covariances) in (0, 9 * count),
        "not 9 covariance values per estimate, nor none",
    )
    paths = _ragged_from_message(message.path_offsets, message.path_ids, count, swarm, "path")
    radio_paths = _ragged_from_message(
        message.radio_path_offsets, message.radio_path_ids, count, swarm, "radio_path"
    )
    check_ids(message.target_ids, swarm, "estimates")
    check_ids([message.source_id], swarm, "estimates")
    statuses, reasons = np.asarray(message.statuses), np.asarray(message.reasons)
    check(
        bool(np.all(statuses < len(STATUS_NAMES)) and np.all(reasons < len(REASON_NAMES))),
        "unknown status or reason",
    )
    estimators = _ESTIMATOR_INDEX[np.asarray(message.estimators, dtype=np.uint8)]
    check(bool(np.all(estimators >= 0)), "unknown estimator")
    vectors = check_finite(message.vectors, "vector", allow_nan=True).reshape(count, 3)
    lengths = check_finite(message.path_lengths, "path_lengths", allow_nan=True)
    predicted = check_finite(message.predicted_errors, "predicted_errors", allow_nan=True)
    covariances = _covariances(message.covariances, count)
    # Ids kept in the wire's 4 bytes, not 8: the coordinator holds every source's report to
    # its run's end, about 10 ids an estimate (9.5 M estimates on torus:30000).
    return Estimates(
        np.asarray(message.target_ids, dtype=np.uint32),
        statuses.astype(np.int8),
        reasons.astype(np.int8),
        paths[0],
        paths[1].astype(np.uint32),
        lengths,
        vectors,
        radio_paths[0],
        radio_paths[1].astype(np.uint32),
        predicted,
        estimators,
        covariances,
    )


def _covariances(values: Sequence[float], count: int) -> FloatArray:
    """A report's ``count`` covariances (count, 3, 3), cm^2, NaN where an estimate has none
    (a fit's is whole or absent; a report without any sends none): where none has one, one
    NaN read ``count`` times, for the coordinator holds every report to its run's end."""
    if len(values) == 0:
        return np.broadcast_to(np.float64(np.nan), (count, 3, 3))
    covariances = check_finite(values, "covariance", allow_nan=True).reshape(count, 3, 3)
    partial = np.asarray(np.isnan(covariances).any(axis=(1, 2)), dtype=bool)
    if partial.all():
        return np.broadcast_to(np.float64(np.nan), (count, 3, 3))
    return np.where(partial[:, None, None], np.nan, covariances)


def checked_offsets(
    offsets: Sequence[int], ids: Sequence[int], count: int, longest: int, what: str, of: str
) -> IntArray:
    """The offsets (count + 1,) of ``count`` paths of at most ``longest`` FLSs into ``ids``.

    MessageError unless there is one more offset than paths, they run from 0
    to the number of ids without decreasing, and ``ids`` could be that many paths.
    """
    if not count and len(offsets) == 1 and offsets[0] == 0 and not len(ids):
        return np.zeros(1, dtype=np.int64)  # no label, no path: most offers late in a run
    check(len(offsets) == count + 1, f"not one more {what} offset than {of}")
    check_size(ids, count * longest, f"{what}_ids")
    bounds = np.asarray(offsets, dtype=np.int64)
    check(bounds[0] == 0 and bounds[-1] == len(ids), f"{what} offsets do not span {what}_ids")
    check(bool((bounds[1:] >= bounds[:-1]).all()), f"{what} offsets decrease")
    return bounds


def _ragged_from_message(
    offsets: Sequence[int], ids: Sequence[int], count: int, swarm: IntArray, what: str
) -> tuple[IntArray, IntArray]:
    """The ``count`` paths of a ragged (offsets, ids) pair, checked against ``swarm``."""
    bounds = checked_offsets(offsets, ids, count, len(swarm), what, "estimates")
    check(bool(np.all(np.diff(bounds) <= len(swarm))), "a path longer than the swarm")
    return bounds, check_ids(ids, swarm, f"estimates' {what}s")


def pose_estimate_from_message(message: PoseEstimate) -> Estimate:
    """The core's Estimate (cm) of a PoseEstimate (m), for people: not the protocol's bits."""
    vector = message.vector
    covariance = np.asarray(message.covariance, dtype=np.float64).reshape(3, 3)
    fitted = np.isfinite(covariance).all()
    return Estimate(
        target=int(message.target_id),
        status=int(message.status),
        reason=int(message.reason),
        path=tuple(int(fls) for fls in message.path),
        length=float(message.path_length) * CM_PER_METRE,
        vector=np.array([vector.x, vector.y, vector.z]) * CM_PER_METRE,
        radio_path=tuple(int(fls) for fls in message.radio_path),
        predicted_error=float(message.predicted_error) * CM_PER_METRE,
        estimator=ESTIMATOR_NAMES.get(message.estimator, PATH),
        covariance=covariance * CM_PER_METRE**2 if fitted else None,
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
        fit_stage=control.fit.stage,
        fit_layer=control.fit.layer,
        fit_mode=control.fit.mode,
        fit_ended=control.fit.ended,
        reach_pass=control.reach_pass,
        exhausted_ids=list(control.exhausted_ids),
    )
    message.fit_sums = packed(np.asarray(control.fit.sums, dtype=np.float64), np.float64)
    message.header.stamp = stamp
    return message


def control_from_message(message: DiscoveryControl, swarm: IntArray) -> Control:
    """The round clock's tick of a DiscoveryControl message to the FLSs of ``swarm`` (sorted ids).

    MessageError for an unknown command, phase or policy, an id not in the swarm,
    or targets that do not pair with the sources.
    """
    check(message.command in (START, ROUND, END), f"unknown command {message.command}")
    check(message.phase in RUN_PHASES, f"unknown phase {message.phase}")
    check(message.policy in POLICY_NAMES, f"unknown policy {message.policy}")
    check(message.estimator in ESTIMATOR_NAMES, f"unknown estimator {message.estimator}")
    check(message.expected <= len(swarm), f"expects {message.expected} FLSs, more than the swarm")
    lists = {}
    for name in ("source_ids", "target_ids", "finished_ids", "departed_ids", "exhausted_ids"):
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
        source_ids=lists["source_ids"],
        target_ids=lists["target_ids"],
        finished_ids=lists["finished_ids"],
        departed_ids=lists["departed_ids"],
        estimator=ESTIMATOR_NAMES[message.estimator],
        fit=_fit_step(message),
        reach_pass=int(message.reach_pass),
        exhausted_ids=lists["exhausted_ids"],
    )


def _fit_step(message: DiscoveryControl) -> FitStep:
    """The FIT phase's step of a DiscoveryControl; MessageError for unknown codes."""
    check(message.fit_stage < len(STAGE_NAMES), f"unknown fit stage {message.fit_stage}")
    check(message.fit_mode <= SAMPLES, f"unknown fit mode {message.fit_mode}")
    check(message.fit_ended <= STALLED, f"unknown fit ending {message.fit_ended}")
    check_size(message.fit_sums, FIT_VALUES, "fit_sums")
    sums = check_finite(message.fit_sums, "fit_sums")
    return FitStep(
        int(message.fit_stage),
        int(message.fit_layer),
        int(message.fit_mode),
        tuple(sums.tolist()),
        int(message.fit_ended),
    )


def ack_message(ack: Ack, host: str, stamp: Time) -> RoundAck:
    """A process's acknowledgement that it delivered a round, as a RoundAck message."""
    message = RoundAck(
        run_id=ack.run_id,
        phase=ack.phase,
        round=ack.round,
        delivered=True,
        heard=ack.heard,
        repairs=ack.repairs,
        lost=ack.lost,
    )
    message.host = host
    message.header.stamp = stamp
    return message


def heartbeat_message(alive: Alive, stamp: Time) -> Heartbeat:
    """A radio's word that it is alive, as a Heartbeat message."""
    message = Heartbeat(
        hears_controls=alive.hears_controls,
        run_id=alive.run_id,
        round=alive.round,
        late=alive.late,
    )
    message.host = alive.host
    message.header.stamp = stamp
    return message


#: Seconds a heartbeat may say its executor looked late, at most: a day.
MAX_LATE = 86400.0


def alive_from_message(message: Heartbeat) -> Alive:
    """What a Heartbeat says; MessageError for a lateness that is no time (NaN, < 0, > a day)."""
    late = float(message.late)
    check(math.isfinite(late) and 0.0 <= late <= MAX_LATE, f"late {late} is not 0..{MAX_LATE:g} s")
    return Alive(
        message.host, bool(message.hears_controls), int(message.run_id), int(message.round), late
    )


def sent_message(control: Control, sent: Sent, host: str, stamp: Time) -> RoundAck:
    """What a process's FLSs broadcast in ``control``'s round, as a RoundAck message."""
    message = RoundAck(
        run_id=control.run_id,
        phase=control.phase,
        round=control.round,
        delivered=False,
        sender_ids=list(sent.senders),
        labels=sent.labels,
        pending_ids=list(sent.pending),
        finished_ids=list(sent.finished),
        offer_bytes=sent.bytes,
        fit_moved=sent.fit_moved,
        fit_huber_same=sent.fit_same[0],
        fit_rejecting_same=sent.fit_same[1],
        beyond_ids=list(sent.beyond),
        searching_ids=list(sent.searching),
        label_bytes=sent.label_bytes,
    )
    message.fit_sums = packed(np.asarray(sent.fit_sums, dtype=np.float64), np.float64)
    message.host = host
    message.header.stamp = stamp
    return message


def sent_from_message(message: RoundAck, swarm: IntArray) -> Sent:
    """What a RoundAck says FLSs of ``swarm`` (sorted ids) sent; MessageError if it cannot be."""
    lists = {}
    for name in ("sender_ids", "pending_ids", "finished_ids", "beyond_ids", "searching_ids"):
        values = getattr(message, name)
        check_size(values, len(swarm), name)
        lists[name] = tuple(check_ids(values, swarm, name).tolist())
    senders = set(lists["sender_ids"])
    check(
        set(lists["pending_ids"]) <= senders
        and set(lists["finished_ids"]) <= senders
        and set(lists["searching_ids"]) <= senders,
        "pending, finished or searching FLSs that did not send",
    )
    check_size(message.fit_sums, FIT_VALUES, "fit_sums")
    moved = float(check_finite([message.fit_moved], "fit_moved")[0])
    check(moved >= 0.0, "a negative move")
    return Sent(
        lists["sender_ids"],
        int(message.labels),
        lists["pending_ids"],
        lists["finished_ids"],
        int(message.offer_bytes),
        tuple(check_finite(message.fit_sums, "fit_sums").tolist()),
        moved,
        (bool(message.fit_huber_same), bool(message.fit_rejecting_same)),
        lists["beyond_ids"],
        lists["searching_ids"],
        int(message.label_bytes),
    )


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


def walk_fields(walk: Walk, stamp: Time) -> Fields:
    """A path walk: a PathWalk message's fields by name (:mod:`..security.records`)."""
    return {
        "header.stamp.sec": stamp.sec,
        "header.stamp.nanosec": stamp.nanosec,
        "run_id": walk.run_id,
        "revision": walk.revision,
        "source_id": walk.source_id,
        "target_id": walk.target_id,
        "path": walk.path,
        "hop": walk.hop,
        "state": walk.state,
        "vector.x": float(walk.vector[0]),
        "vector.y": float(walk.vector[1]),
        "vector.z": float(walk.vector[2]),
    }


def walk_message(walk: Walk, stamp: Time) -> PathWalk:
    """A path walk as a PathWalk message (:func:`walk_fields`)."""
    message: PathWalk = message_of(PathWalk, walk_fields(walk, stamp))
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
