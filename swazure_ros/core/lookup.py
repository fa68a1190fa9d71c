"""Where values are in a sorted array of distinct ids: the rows of many at once.

Every table of the package keyed by FLS id keeps its ids sorted, each once
(a swarm's ids, a process's FLSs, a round's senders, a source's targets),
and finds the rows of many ids by binary search. A swarm's ids are its
cloud's rows, most often 0..N-1 without a gap; then each id is its own
row, found without a search. That is the case where the most ids are looked
up: each path id of every label a process hears from another is checked
against the swarm's ids when its offer arrives, and placed by them when its
plausibility is checked (millions a round at display scale).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .arrays import BoolArray, IntArray

__all__ = ["sorted_rows"]


def sorted_rows(values: IntArray, wanted: ArrayLike) -> tuple[IntArray, BoolArray]:
    """The row of each of ``wanted`` in ``values``, and whether it is there.

    Parameters
    ----------
    values : (N,) array of int
        Sorted, each value once (the function does not check it).
    wanted : array_like of int
        The values to find, any order and shape (taken flat, M of them).

    Returns
    -------
    rows : (M,) int64 array
        Each value's row in ``values`` where it is there; elsewhere the row
        it would be inserted at, or the last row in place of one past the end
        (0 when ``values`` is empty), so that ``values[rows]`` may always be
        read when N > 0.
    found : (M,) bool array
        Whether each value of ``wanted`` is in ``values``.

    Notes
    -----
    When ``values`` is 0..N-1 each value is its own row: the rows and
    whether each is there are those of the binary search, without it.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.lookup import sorted_rows
    >>> rows, found = sorted_rows(np.array([2, 5, 9]), [5, 3, 9, 12])
    >>> rows.tolist(), found.tolist()
    ([1, 1, 2, 2], [True, False, True, False])
    >>> rows, found = sorted_rows(np.arange(4), [3, -1, 7])
    >>> rows.tolist(), found.tolist()
    ([3, 0, 3], [True, False, False])
    """
    wanted = np.asarray(wanted, dtype=np.int64).reshape(-1)
    count = len(values)
    if not count:
        return np.zeros(len(wanted), dtype=np.int64), np.zeros(len(wanted), dtype=bool)
    if values[0] == 0 and values[-1] == count - 1:
        # Distinct and sorted from 0 to N - 1: every value is its row.
        # minimum and maximum, not clip: clip's checks cost 10 us, most of a message's ids'.
        return np.minimum(np.maximum(wanted, 0), count - 1), (wanted >= 0) & (wanted < count)
    rows = np.minimum(np.searchsorted(values, wanted), count - 1)
    return rows, values[rows] == wanted
