"""Ragged arrays laid out flat (CSR): run k of N is ``values[offsets[k]:offsets[k + 1]]``.

Paths, per-FLS neighbours, readings and labels are all kept this way; these
functions are the only place the layout's arithmetic is written.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import IntArray


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


def take(
    bounds: ArrayLike, values: NDArray[Any], runs: ArrayLike
) -> tuple[IntArray, NDArray[Any]]:
    """Runs ``runs`` (M,) of the table (``bounds`` (N + 1,), ``values``), in that order:
    their (offsets (M + 1,), values)."""
    bounds = np.asarray(bounds, dtype=np.int64)
    runs = np.asarray(runs, dtype=np.int64)
    starts, counts = bounds[runs], bounds[runs + 1] - bounds[runs]
    return offsets(counts), values[ragged_indices(starts, counts)]


def join(
    tables: list[tuple[IntArray, NDArray[Any]]], empty: NDArray[Any]
) -> tuple[IntArray, NDArray[Any]]:
    """Ragged tables (offsets, values), one after the other, as one; ``empty`` if none."""
    if not tables:
        return np.zeros(1, dtype=np.int64), empty
    counts = np.concatenate([np.diff(bounds) for bounds, _ in tables])
    return offsets(counts), np.concatenate([values for _, values in tables])
