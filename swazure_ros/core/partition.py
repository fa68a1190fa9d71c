"""Compact regions of a swarm: a k-d split of its points into parts of near-equal size."""

from __future__ import annotations

import numpy as np

from .arrays import FloatArray, IntArray


def kd_split(points: FloatArray, parts: int) -> list[IntArray]:
    """Rows of ``points`` (N, 3), cm, in ``parts`` compact regions, sizes apart by one at most.

    Each split cuts the widest axis of a region's bounding box at the point
    that gives its two halves sizes in the ratio of the parts they hold
    (``parts // 2`` and the rest). Ties on the axis keep the rows' order
    (a stable sort), so the split is the same on every machine.

    Parameters
    ----------
    points : (N, 3) array of float, cm
    parts : int
        Regions, from 1 to N.

    Returns
    -------
    list of (K,) array of int
        ``parts`` arrays of rows of ``points``, each sorted, sizes apart by one
        at most; the regions in k-d order.

    Raises
    ------
    ValueError
        ``parts`` below 1, or above N.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.partition import kd_split
    >>> line = np.array([[0.0, 0, 0], [10, 0, 0], [1, 0, 0], [11, 0, 0], [5, 0, 0]])
    >>> [part.tolist() for part in kd_split(line, 2)]
    [[0, 2, 4], [1, 3]]
    """
    if parts < 1:
        raise ValueError(f"parts must be at least 1, got {parts}")
    if parts > len(points) > 0:
        raise ValueError(f"{parts} parts for {len(points)} points: too many")
    rows = np.arange(len(points), dtype=np.int64)
    return [np.sort(part) for part in _split(np.asarray(points, dtype=np.float64), rows, parts)]


def _split(points: FloatArray, rows: IntArray, parts: int) -> list[IntArray]:
    if parts == 1:
        return [rows]
    first = parts // 2
    # The larger parts first, as np.array_split spreads N points.
    cut = -(-len(rows) * first // parts)
    here = points[rows]
    axis = int(np.argmax(np.ptp(here, axis=0))) if len(rows) else 0
    order = np.argsort(here[:, axis], kind="stable")
    return _split(points, rows[order[:cut]], first) + _split(
        points, rows[order[cut:]], parts - first
    )
