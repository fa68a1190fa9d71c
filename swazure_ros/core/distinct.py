"""Distinct values of an index array, and each value's rank among them.

A block of paths crosses some of a graph's slots or a swarm's pairs, many
times over; each is worked on once and the hops find their row again by rank.
How that is fastest depends on how many of the indices are crossed, so it is
decided here, once.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .arrays import IntArray

# Up to this many possible values per index given, a mark per possible value and
# their running count beat a sort: 0.03 against 0.12 s for 2 M indices into 2 M, and
# 0.34 against 0.8 s for 5 M into 10 M; 1 M into 10 M is 0.14 against 0.04 s
# (BENCHMARKS.md, "The decaying pairs in sight held smaller").
DENSE_SPREAD = 4


def distinct_ranks(values: ArrayLike, bound: int) -> tuple[IntArray, IntArray]:
    """The distinct values of ``values`` in increasing order, and each value's rank.

    Parameters
    ----------
    values : (H,) array_like of int
        Indices in ``[0, bound)``, in any order, repeated or not.
    bound : int
        One more than the largest index possible (a graph's slots, a swarm's
        pairs).

    Returns
    -------
    distinct : (K,) ndarray of int
        The values that occur, increasing.
    ranks : (H,) ndarray of int
        ``distinct[ranks] == values``.

    Raises
    ------
    ValueError
        A value is negative or not below ``bound``.

    Notes
    -----
    With few values against ``bound`` the work is a sort of the values
    (``np.unique``); with many, a mark per possible index and their running
    count, in ``O(bound)`` memory. Both give the same arrays.

    Examples
    --------
    >>> from swazure_ros.core.distinct import distinct_ranks
    >>> distinct, ranks = distinct_ranks([7, 2, 7, 5], bound=10)
    >>> distinct.tolist(), ranks.tolist()
    ([2, 5, 7], [2, 0, 2, 1])
    """
    values = np.asarray(values, dtype=np.int64).reshape(-1)
    if len(values) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    if int(values.min()) < 0 or int(values.max()) >= bound:
        raise ValueError(f"indices must lie in [0, {bound})")
    if bound > DENSE_SPREAD * len(values):
        # np.unique(values) alone hashes (numpy 2.4 here): 5 s for 5 M values, and
        # a search of each in the result as long again; its inverse sorts instead.
        distinct, ranks = np.unique(values, return_inverse=True)
        return distinct.astype(np.int64, copy=False), ranks.astype(np.int64, copy=False)
    marked = np.zeros(bound, dtype=bool)
    marked[values] = True
    distinct = np.flatnonzero(marked)
    rank_of = np.cumsum(marked, dtype=np.int64)
    return distinct.astype(np.int64, copy=False), rank_of[values] - 1
