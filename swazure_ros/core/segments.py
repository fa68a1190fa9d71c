"""Points and segments in space: the nearest point of a segment, distances to segments.

The segments are the straight moves of FLSs (Move Obstructing's,
:mod:`.heuristics.obstructing`, and a swarm's batches of moves,
``protocol.schedule``); the compiled kernels find whether points come within
reach of them.
"""

from __future__ import annotations

import numpy as np

from . import jit
from .arrays import FloatArray


@jit.kernel(cache=True, nogil=True)
def closest_on_segment(start: FloatArray, end: FloatArray, point: FloatArray) -> FloatArray:
    """The point of the segment start-end nearest ``point``, cm (compiled).

    Parameters
    ----------
    start, end : (3,) array of float, cm
        The segment's ends, distinct.
    point : (3,) array of float, cm

    Returns
    -------
    (3,) array of float, cm
        The projection of ``point`` onto the segment, clamped to its ends.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.segments import closest_on_segment
    >>> closest_on_segment(np.zeros(3), np.array([4.0, 0, 0]), np.array([1.0, 2, 0]))
    array([1., 0., 0.])
    """
    direction = end - start
    along = float((point - start) @ direction / (direction @ direction))
    return start + min(max(along, 0.0), 1.0) * direction


@jit.kernel(cache=True, nogil=True, error_model="numpy")
def segment_gap(point: FloatArray, start: FloatArray, end: FloatArray) -> float:
    """Distance of ``point`` to the segment start-end, cm (compiled).

    Parameters
    ----------
    point : (3,) array of float, cm
    start, end : (3,) array of float, cm
        The segment's ends, distinct.

    Returns
    -------
    float, cm
        The distance to the nearest point of the segment.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.segments import segment_gap
    >>> segment_gap(np.array([5.0, 3, 0]), np.zeros(3), np.array([4.0, 0, 0]))
    3.1622776601683795
    """
    dx, dy, dz = end[0] - start[0], end[1] - start[1], end[2] - start[2]
    ox, oy, oz = point[0] - start[0], point[1] - start[1], point[2] - start[2]
    along = min(max((ox * dx + oy * dy + oz * dz) / (dx * dx + dy * dy + dz * dz), 0.0), 1.0)
    gx = point[0] - (start[0] + along * dx)
    gy = point[1] - (start[1] + along * dy)
    gz = point[2] - (start[2] + along * dz)
    return float(np.sqrt(gx * gx + gy * gy + gz * gz))


@jit.kernel(cache=True, nogil=True)
def near_any_segment(
    points: FloatArray, starts: FloatArray, ends: FloatArray, reach: float
) -> bool:
    """Whether any point is closer than ``reach`` to any segment (compiled).

    Parameters
    ----------
    points : (K, 3) array of float, cm
    starts, ends : (S, 3) array of float, cm
        Segment s runs from ``starts[s]`` to ``ends[s]``.
    reach : float, cm
        The distance a point must stay at, or beyond.

    Returns
    -------
    bool
        True at the first point strictly closer than ``reach`` to a segment.
    """
    for s in range(len(starts)):
        for k in range(len(points)):
            if segment_gap(points[k], starts[s], ends[s]) < reach:
                return True
    return False
