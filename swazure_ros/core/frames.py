"""Frames and units of what the swarm publishes (docs/frames.md).

The model computes in centimetres; ROS messages carry metres.

The spec and every table of the study are in centimetres, and so is the
core. REP-103 asks SI units of messages that other ROS software reads
(docs/frames.md), so conversions happen once, where a message is made or
read. Dividing by 100 is correctly rounded, where multiplying by 0.01 is not
(0.01 has no exact binary value): a metre value is the nearest double to
the true quotient.
"""

from __future__ import annotations

from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

#: Centimetres in a metre.
CM_PER_METRE = 100.0
#: Metres in a centimetre, for drawing (RViz markers) where a last bit does not matter.
METRES_PER_CM = 1.0 / CM_PER_METRE

Value = TypeVar("Value", float, NDArray[np.float64])


def to_metres(centimetres: Value) -> Value:
    """Centimetres in metres: divided by 100, correctly rounded.

    Parameters
    ----------
    centimetres : float or array of float, cm

    Returns
    -------
    float or array of float, m
        Of the argument's kind.

    Examples
    --------
    >>> from swazure_ros.core.frames import to_metres
    >>> to_metres(250.0)
    2.5
    """
    return centimetres / CM_PER_METRE


def to_centimetres(metres: Value) -> Value:
    """Metres in centimetres.

    Parameters
    ----------
    metres : float or array of float, m

    Returns
    -------
    float or array of float, cm
        Of the argument's kind.
    """
    return metres * CM_PER_METRE


def through_metres(centimetres: Value) -> Value:
    """Centimetres as they read back from a message in metres (REP-103): the same bits.

    Not always the value sent: x / 100 * 100 may differ from x in its last
    bit. What an FLS computes from its neighbours' messages, the engine
    computes from these.

    Parameters
    ----------
    centimetres : float or array of float, cm

    Returns
    -------
    float or array of float, cm

    Examples
    --------
    >>> from swazure_ros.core.frames import through_metres
    >>> through_metres(1.85)
    1.8500000000000003
    """
    return to_centimetres(to_metres(centimetres))


#: The fixed frame of a display: the frame its shape's points are given in.
SWARM_FRAME = "swarm"


def fls_frame(fls_id: int) -> str:
    """FLS ``fls_id``'s frame: origin at its centre, axes parallel to the swarm frame's.

    Parameters
    ----------
    fls_id : int

    Returns
    -------
    str
        ``fls_<id>``.
    """
    return f"fls_{fls_id}"


def camera_optical_frame(fls_id: int) -> str:
    """The optical frame of FLS ``fls_id``'s camera: z along the view, x right, y down.

    Parameters
    ----------
    fls_id : int

    Returns
    -------
    str
        ``fls_<id>_camera_optical``.
    """
    return f"fls_{fls_id}_camera_optical"
