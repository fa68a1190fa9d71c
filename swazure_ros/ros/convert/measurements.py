"""Measurements messages as CDR bytes, written and read with numpy.

An FLS measures hundreds of neighbours (on a thousand-FLS sphere, about 700
each). Made as a Measurements object, signed field by field and serialised by
rclpy, one message took 0.11 s to send, and rclpy took 0.1 s more to make the
object again for a reader: a reader that joined a thousand-FLS swarm waited
minutes for what the latched history held. Every pose of a message carries the
message's header, so the poses lie alike in CDR (a pose ends with float64s:
each one after the first starts 8-aligned) and are one numpy record array; so
is what the tag covers (:func:`..security.auth.content`). The bytes are
``cdr.serialize``'s of the same message, signed with the same tag.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import NDArray

from ...core.arrays import FloatArray, IntArray
from ...core.errors import MessageError
from ...core.frames import fls_frame, to_centimetres, to_metres
from ...core.observe import Measurement
from ...core.sensor import DECAYING, SWEET
from ...protocol.readings import Readings
from ..plumbing.cdr import aligned
from ..security.auth import SwarmKey
from ..security.guard import check, check_finite, check_ids, check_size

__all__ = ["MeasurementsBytes", "measurements_bytes", "read_measurements", "readings_of"]

#: CDR (XCDR1) little-endian, no options: the encapsulation header rmw_fastrtps writes.
LITTLE_ENDIAN = b"\x00\x01\x00\x00"
#: The header: its stamp (int32 sec, uint32 nanosec) and its frame id's length with the NUL.
_HEAD = struct.Struct("<iII")
_WORD = struct.Struct("<I")
#: A length in what the tag covers (:func:`..security.auth.content`): 8 bytes.
_LENGTH = struct.Struct("<Q")
#: The fields a pose has of its own (not its header's), by name in both records.
_POSE_FIELDS = (
    "source_id", "target_id", "range_class", "line_of_sight", "vector",
    "tracking_distance", "radio_distance",
)  # fmt: skip
#: One pose's primitives as the tag covers them, packed, then its frame id (the length as
#: 8 bytes and the characters, which the caller appends).
_COVERED_POSE = [
    ("sec", "<i4"), ("nanosec", "<u4"), ("source_id", "<u4"), ("target_id", "<u4"),
    ("range_class", "u1"), ("line_of_sight", "u1"), ("vector", "<f8", (3,)),
    ("tracking_distance", "<f8"), ("radio_distance", "<f8"),
]  # fmt: skip


@dataclass(frozen=True)
class MeasurementsBytes:
    """A Measurements message read from its CDR bytes (:func:`read_measurements`).

    Attributes
    ----------
    source_id : int
        The measuring FLS.
    stamp : (2,) int
        The header's stamp: seconds and nanoseconds.
    pose_source_ids : (K,) int64
        Each pose's measuring FLS (the message's, in a message that is right).
    target_ids : (K,) int64
        The measured FLSs.
    range_class : (K,) int8
        Each pose's RelativePose.RANGE_*.
    vector : (K, 3) float, cm
        Source to target in the source's frame.
    tracking : (K,) float, cm
        Surface-to-surface distances as measured.
    radio_distance : (K,) float, cm
        Distances by radio ranging (NaN where not given).
    line_of_sight : (K,) bool
        False where known by radio only.
    auth : bytes
        The ``auth`` field.
    content : bytes
        What the tag covers (:func:`..security.auth.content` of the message).
    """

    source_id: int
    stamp: tuple[int, int]
    pose_source_ids: NDArray[np.int64]
    target_ids: NDArray[np.int64]
    range_class: NDArray[np.int8]
    vector: FloatArray
    tracking: FloatArray
    radio_distance: FloatArray
    line_of_sight: NDArray[np.bool_]
    auth: bytes
    content: bytes


def measurements_bytes(
    fls_id: int,
    measurement: Measurement,
    stamp: Time,
    key: SwarmKey,
    radio_distance: FloatArray | None = None,
) -> bytes:
    """One FLS's camera measurements as a signed Measurements message's CDR bytes.

    The bytes of ``key.serialize(measurements_message(...))``: metres in the
    FLS's frame, every pose stamped as the message and in line of sight.

    Parameters
    ----------
    fls_id : int
        The measuring FLS.
    measurement : Measurement
        Its K readings (cm).
    stamp : builtin_interfaces/Time
        When they were sensed.
    key : SwarmKey
        Signs the message (``auth`` stays empty without a key).
    radio_distance : (K,) float, cm, optional
        Each measured pair's distance by radio ranging (NaN where not given).

    Returns
    -------
    bytes
        The encapsulation header and the message.
    """
    count = len(measurement.target_ids)
    frame = fls_frame(fls_id).encode()
    radio = np.full(count, np.nan) if radio_distance is None else np.asarray(radio_distance)
    fields: dict[str, Any] = {
        "source_id": fls_id,
        "target_id": measurement.target_ids,
        "range_class": measurement.range_class,
        "line_of_sight": 1,
        "vector": to_metres(measurement.vector),
        "tracking_distance": to_metres(measurement.tracking),
        "radio_distance": to_metres(radio),
    }
    auth = key.auth(_content(stamp.sec, stamp.nanosec, fls_id, frame, fields, count))
    # The message: its header, source id and the poses' count, the poses, the tag.
    head = _HEAD.pack(stamp.sec, stamp.nanosec, len(frame) + 1) + frame + b"\0"
    start = aligned(len(head), 4)
    layouts, end = _layouts(start + 8, frame, count)
    at = aligned(end, 4)
    body = np.zeros(at + 4 + len(auth), dtype=np.uint8)
    body[: len(head)] = np.frombuffer(head, dtype=np.uint8)
    body[start : start + 8] = np.frombuffer(_WORD.pack(fls_id) + _WORD.pack(count), np.uint8)
    first = 0
    for dtype, offset, rows in layouts:
        poses = np.ndarray((rows,), dtype=dtype, buffer=body, offset=offset)
        poses["stamp"] = (stamp.sec, stamp.nanosec)
        poses["frame"] = _cdr_string(frame)
        for name, value in fields.items():
            poses[name] = value[first : first + rows] if np.ndim(value) else value
        first += rows
    body[at:] = np.frombuffer(_WORD.pack(len(auth)) + auth, dtype=np.uint8)
    return LITTLE_ENDIAN + body.tobytes()


def read_measurements(data: bytes) -> MeasurementsBytes:
    """A Measurements message's fields from its CDR bytes.

    MessageError when the bytes are not a little-endian Measurements message
    whose every pose carries the message's header (as every FLS sends them).
    """
    view = memoryview(data)
    if bytes(view[:2]) != LITTLE_ENDIAN[:2] or len(view) < 4 + _HEAD.size:
        raise MessageError("not a Measurements message in little-endian CDR")
    body = view[4:]
    try:
        sec, nanosec, length = _HEAD.unpack_from(body, 0)
        frame = bytes(body[_HEAD.size : _HEAD.size + length]).rstrip(b"\0")
        start = aligned(_HEAD.size + length, 4)
        source_id, count = struct.unpack_from("<II", body, start)
        layouts, end = _layouts(start + 8, frame, count)
        parts = [np.ndarray((n,), dtype, buffer=body, offset=at) for dtype, at, n in layouts]
        at = aligned(end, 4)
        (size,) = _WORD.unpack_from(body, at)
        auth = bytes(body[at + 4 : at + 4 + size])
    except (struct.error, TypeError, ValueError) as err:
        raise MessageError("CDR bytes end inside their Measurements") from err
    if len(auth) != size:
        raise MessageError("CDR bytes end inside their Measurements")
    # The first pose may lie otherwise than the rest: the same fields, taken by name.
    poses = np.concatenate([part.astype(parts[-1].dtype) for part in parts]) if parts else None
    if poses is None:
        poses = np.zeros(0, dtype=_pose_dtype(0, frame)[0])
    if not (
        np.all(poses["frame"] == _cdr_string(frame)) and np.all(poses["stamp"] == (sec, nanosec))
    ):
        raise MessageError("a pose's header is not its message's")
    return MeasurementsBytes(
        source_id=int(source_id),
        stamp=(int(sec), int(nanosec)),
        pose_source_ids=poses["source_id"].astype(np.int64),
        target_ids=poses["target_id"].astype(np.int64),
        range_class=poses["range_class"].astype(np.int8),
        vector=to_centimetres(poses["vector"].astype(np.float64)),
        tracking=to_centimetres(poses["tracking_distance"].astype(np.float64)),
        radio_distance=to_centimetres(poses["radio_distance"].astype(np.float64)),
        line_of_sight=poses["line_of_sight"] != 0,
        auth=auth,
        content=_content(sec, nanosec, source_id, frame, poses, count),
    )


def readings_of(message: MeasurementsBytes, swarm: IntArray) -> Readings:
    """The camera readings (cm) of a Measurements message from an FLS of ``swarm`` (sorted ids).

    MessageError unless every pose is the source's, of an FLS of the swarm
    once, in sweet or decaying range, with a finite vector and radio distance.
    """
    check_size(message.target_ids, len(swarm), "poses")
    source = message.source_id
    check(bool(np.all(message.pose_source_ids == source)), "a pose of another FLS")
    other = check_ids(np.append(source, message.target_ids), swarm, "poses")[1:]
    check(len(np.unique(other)) == len(other), "an FLS measured twice")
    check(source not in other, "an FLS measures itself")
    range_class = message.range_class
    check(bool(np.isin(range_class, (SWEET, DECAYING)).all()), "a reading out of camera range")
    check_finite(message.vector, "poses")
    check_finite(message.radio_distance, "poses")
    order = np.argsort(other, kind="stable")
    return Readings(
        source,
        other[order],
        range_class[order],
        message.radio_distance[order],
        message.vector[order],
    )


def _content(
    sec: int, nanosec: int, source_id: int, frame: bytes, poses: Any, count: int
) -> bytes:
    """What the tag covers (auth.content) of a message whose ``count`` poses' fields
    (:data:`_POSE_FIELDS`, a record array's or arrays by name) are ``poses``: the
    primitives, the frame id, then each pose's primitives and frame id."""
    covered = np.zeros(count, dtype=[*_COVERED_POSE, ("frame", f"V{8 + len(frame)}")])
    for name in _POSE_FIELDS:
        covered[name] = poses[name]
    covered["sec"], covered["nanosec"] = sec, nanosec
    covered["frame"] = np.void(_LENGTH.pack(len(frame)) + frame)
    return b"".join(
        (
            struct.pack("<iII", sec, nanosec, source_id),
            _LENGTH.pack(len(frame)) + frame,
            _LENGTH.pack(count),
            covered.tobytes(),
        )
    )


def _cdr_string(text: bytes) -> np.void:
    """``text`` as CDR writes a string: its length with the NUL, the characters, the NUL."""
    return np.void(_WORD.pack(len(text) + 1) + text + b"\0")


def _layouts(start: int, frame: bytes, count: int) -> tuple[list[tuple[np.dtype, int, int]], int]:
    """(record dtype, offset, rows) of ``count`` poses from ``start`` (after the
    encapsulation): the first alone, the rest alike from where it ends, 8-aligned; and
    where the poses end."""
    if count == 0:
        return [], start
    first, end = _pose_dtype(start, frame)
    if count == 1:
        return [(first, start, 1)], end
    rest, _ = _pose_dtype(end, frame)
    return [(first, start, 1), (rest, end, count - 1)], end + (count - 1) * rest.itemsize


def _pose_dtype(start: int, frame: bytes) -> tuple[np.dtype, int]:
    """The CDR record of a pose that starts at ``start`` (4-aligned), and where it ends.

    The stamp, the frame id (a uint32 length, the characters and a NUL), the
    ids and classes (4-aligned), the five float64s (8-aligned).
    """
    text = 8 + 4 + len(frame) + 1
    ids = aligned(start + text, 4) - start
    numbers = aligned(start + ids + 10, 8) - start
    dtype = np.dtype(
        {
            "names": ["stamp", "frame", "source_id", "target_id", "range_class",
                      "line_of_sight", "vector", "tracking_distance", "radio_distance"],
            "formats": [("<i4", (2,)), f"V{text - 8}", "<u4", "<u4", "u1", "u1",
                        ("<f8", (3,)), "<f8", "<f8"],
            "offsets": [0, 8, ids, ids + 4, ids + 8, ids + 9, numbers, numbers + 24,
                        numbers + 32],
            "itemsize": numbers + 40,
        }
    )  # fmt: skip
    return dtype, start + numbers + 40
