"""Vectors, stamps and units of messages: cm in the core, metres (REP-103) on the wire."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3

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
