"""Ragged arrays laid out flat (CSR): run k of N is ``values[offsets[k]:offsets[k + 1]]``.

Paths, per-FLS neighbours, readings and labels are all kept this way; these
functions are the only place the layout's arithmetic is written.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

IntArray = NDArray[np.int64]


def offsets(counts: ArrayLike) -> IntArray:
    """(N + 1,) where each of N runs of ``counts`` (N,) items starts, and where the last ends."""
    return np.concatenate([[0], np.cumsum(np.asarray(counts, dtype=np.int64))]).astype(np.int64)


def ragged_indices(starts: ArrayLike, counts: ArrayLike) -> IntArray:
    """(sum(counts),) the indices starts[k] .. starts[k] + counts[k] - 1, run after run."""
    starts = np.asarray(starts, dtype=np.int64)
    counts = np.asarray(counts, dtype=np.int64)
    before = np.cumsum(counts) - counts
    return np.asarray(
        np.repeat(starts - before, counts) + np.arange(int(counts.sum())), dtype=np.int64
    )


def run_of(offsets: ArrayLike) -> IntArray:
    """(offsets[-1],) the run each item belongs to, for runs laid out by ``offsets`` (N + 1,)."""
    offsets = np.asarray(offsets, dtype=np.int64)
    return np.asarray(np.repeat(np.arange(len(offsets) - 1), np.diff(offsets)), dtype=np.int64)
