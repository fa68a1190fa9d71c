"""Values people give as text, on the command line or in a file: one rule each.

Each function takes the text and returns the value, or raises ``ValueError``
whose message is the reason in one line (``'half' is not a number``). The
command line's option types (``cli.arguments``) and the swarm file
(``files.swarm_file``) check their values by these same rules, so that a value
is refused in the same words wherever it is given.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from ..core.clouds import MAX_POINTS, MIN_RESAMPLE
from ..core.errors import SwazureError
from .reading import regular_file

#: The largest ROS domain id whose DDS ports fit (Linux; the ROS 2 "domain id" design note).
MAX_DOMAIN_ID = 232
#: FLS ids travel in uint32 message fields.
MAX_FLS_ID = 2**32 - 1


def whole_number(text: str) -> int:
    """A whole number."""
    try:
        return int(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a whole number") from None


def number(text: str) -> float:
    """A number."""
    try:
        return float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number") from None


def seed(text: str) -> int:
    """A random seed: a whole number from 0 to 2**63 - 1 (numpy's seeds are not negative)."""
    value = whole_number(text)
    if not 0 <= value < 2**63:
        raise ValueError(f"seed {value} is outside 0..2**63-1")
    return value


def count(text: str) -> int:
    """A count of things, at least 1."""
    value = whole_number(text)
    if value < 1:
        raise ValueError(f"{value}: must be at least 1")
    return value


def resample_count(text: str) -> int:
    """Points of a resampled cloud: a whole number, MIN_RESAMPLE to MAX_POINTS."""
    value = whole_number(text)
    if not MIN_RESAMPLE <= value <= MAX_POINTS:
        raise ValueError(f"{value}: a resampled cloud has {MIN_RESAMPLE} to {MAX_POINTS} points")
    return value


def domain_id(text: str) -> int:
    """A ROS domain id, 0 to MAX_DOMAIN_ID."""
    value = whole_number(text)
    if not 0 <= value <= MAX_DOMAIN_ID:
        raise ValueError(f"{value} is outside 0..{MAX_DOMAIN_ID}")
    return value


def fls_id(text: str) -> int:
    """An FLS id: a whole number that fits the messages' uint32 fields."""
    value = whole_number(text)
    if not 0 <= value <= MAX_FLS_ID:
        raise ValueError(f"FLS id {value} is outside 0..{MAX_FLS_ID}")
    return value


def seconds(text: str) -> float:
    """A duration in seconds, finite and above 0."""
    value = number(text)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{text} s: a duration must be above 0")
    return value


def input_file(text: str) -> Path:
    """A file to read: a regular file (not a folder, a FIFO or a device) this process can read."""
    path = Path(text)
    if path.is_dir():
        raise ValueError(f"{path} is a folder, not a file")
    try:
        # Its status only: a FIFO or /dev/zero is refused here, before a reader opens it.
        regular_file(path, "", None, SwazureError)
    except SwazureError as err:
        raise ValueError(str(err)) from None
    if not os.access(path, os.R_OK):
        raise ValueError(f"{path}: cannot read")
    return path
