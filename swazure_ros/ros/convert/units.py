"""Vectors, stamps and units of messages: cm in the core, metres (REP-103) on the wire."""

from __future__ import annotations

import array
from collections.abc import Mapping
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3
from numpy.typing import ArrayLike

from ...core.arrays import FloatArray
from ...core.frames import to_centimetres


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


def nanoseconds_stamp(nanoseconds: int) -> Time:
    """A builtin_interfaces Time of whole ``nanoseconds`` (>= 0)."""
    return Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)


def stamp_nanoseconds(stamp: Time) -> int:
    """Whole nanoseconds of a builtin_interfaces Time."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def packed(values: ArrayLike, dtype: type[np.generic] | str) -> array.array:  # type: ignore[type-arg]
    """``values`` as the array.array a message's sequence field of ``dtype`` keeps, flat.

    Given a numpy array, rclpy's generated setters copy it element by element
    (9 us for 100 ids); an array.array of the field's type code is taken in
    one copy of its bytes (0.9 us). numpy's type characters for uint8,
    uint32 and float64 are array's own codes.
    """
    data = np.ascontiguousarray(values, dtype=dtype).ravel()
    return array.array(data.dtype.char, data.tobytes())


def message_of(kind: type, fields: Mapping[str, Any]) -> Any:
    """The message of type ``kind`` whose fields are ``fields``, by name (``header.frame_id``):
    what :func:`..security.records.record_writer` writes of the same fields, less its tag."""
    message = kind()
    for name, value in fields.items():
        *outer, last = name.split(".")
        at = message
        for part in outer:
            at = getattr(at, part)
        held = getattr(at, last)
        if isinstance(held, array.array):  # a sequence of numbers: its type code is numpy's
            value = packed(value, held.typecode)
        elif isinstance(held, np.ndarray):  # a fixed array
            value = np.asarray(value, held.dtype)
        setattr(at, last, value)
    return message
