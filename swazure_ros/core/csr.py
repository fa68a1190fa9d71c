"""Ragged arrays laid out flat (CSR): run k of N is ``values[offsets[k]:offsets[k + 1]]``.

Paths, per-FLS neighbours, readings and labels are all kept this way; these
functions are the only place the layout's arithmetic is written.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import IntArray


def offsets(counts: ArrayLike) -> IntArray:
    """Where each of N runs of ``counts`` items starts, and where the last ends.

    Parameters
    ----------
    counts : (N,) array_like of int
        Items per run, >= 0.

    Returns
    -------
    (N + 1,) array of int
        0, then the running sums.

    Examples
    --------
    >>> from swazure_ros.core.csr import offsets
    >>> offsets([2, 0, 3]).tolist()
    [0, 2, 2, 5]
    """
    return np.concatenate([[0], np.cumsum(np.asarray(counts, dtype=np.int64))]).astype(np.int64)


def ragged_indices(starts: ArrayLike, counts: ArrayLike) -> IntArray:
    """The indices starts[k] .. starts[k] + counts[k] - 1, run after run.

    Parameters
    ----------
    starts, counts : (N,) array_like of int
        Each run's first index and length (>= 0).

    Returns
    -------
    (sum(counts),) array of int

    Examples
    --------
    >>> from swazure_ros.core.csr import ragged_indices
    >>> ragged_indices([10, 20], [2, 3]).tolist()
    [10, 11, 20, 21, 22]
    """
    starts = np.asarray(starts, dtype=np.int64)
    counts = np.asarray(counts, dtype=np.int64)
    before = np.cumsum(counts) - counts
    return np.asarray(
        np.repeat(starts - before, counts) + np.arange(int(counts.sum())), dtype=np.int64
    )


def run_of(offsets: ArrayLike) -> IntArray:
    """The run each item belongs to, for runs laid out by ``offsets``.

    Parameters
    ----------
    offsets : (N + 1,) array_like of int
        Non-decreasing, from 0 (:func:`offsets`).

    Returns
    -------
    (offsets[-1],) array of int
        Run numbers 0 .. N - 1; an empty run has no item.

    Examples
    --------
    >>> from swazure_ros.core.csr import run_of
    >>> run_of([0, 2, 2, 5]).tolist()
    [0, 0, 2, 2, 2]
    """
    offsets = np.asarray(offsets, dtype=np.int64)
    return np.asarray(np.repeat(np.arange(len(offsets) - 1), np.diff(offsets)), dtype=np.int64)


def take(
    bounds: ArrayLike, values: NDArray[Any], runs: ArrayLike
) -> tuple[IntArray, NDArray[Any]]:
    """Some runs of a ragged table, in the order asked, as a ragged table of their own.

    Parameters
    ----------
    bounds : (N + 1,) array_like of int
        The table's offsets.
    values : (bounds[-1], ...) array
        The table's items.
    runs : (M,) array_like of int
        Runs to take, 0 .. N - 1, in any order, repeats allowed.

    Returns
    -------
    offsets : (M + 1,) array of int
    values : array
        The runs' items, of ``values``' dtype.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.csr import take
    >>> rows, items = take([0, 2, 2, 5], np.array([7, 8, 9, 10, 11]), [2, 0])
    >>> rows.tolist(), items.tolist()
    ([0, 3, 5], [9, 10, 11, 7, 8])
    """
    bounds = np.asarray(bounds, dtype=np.int64)
    runs = np.asarray(runs, dtype=np.int64)
    starts, counts = bounds[runs], bounds[runs + 1] - bounds[runs]
    return offsets(counts), values[ragged_indices(starts, counts)]


def span(
    bounds: IntArray, values: NDArray[Any], low: int, high: int
) -> tuple[IntArray, NDArray[Any]]:
    """Runs ``low`` .. ``high - 1`` of a ragged table, as a ragged table of their own.

    Parameters
    ----------
    bounds : (N + 1,) array of int
        The table's offsets.
    values : (bounds[-1], ...) array
        The table's items.
    low, high : int
        0 <= low <= high <= N.

    Returns
    -------
    offsets : (high - low + 1,) array of int
        From 0.
    values : array
        A view of the runs' items.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.csr import span
    >>> rows, items = span(np.array([0, 2, 2, 5]), np.array([7, 8, 9, 10, 11]), 1, 3)
    >>> rows.tolist(), items.tolist()
    ([0, 0, 3], [9, 10, 11])
    """
    at = bounds[low : high + 1]
    return at - at[0], values[at[0] : at[-1]]


def join(
    tables: list[tuple[IntArray, NDArray[Any]]], empty: NDArray[Any]
) -> tuple[IntArray, NDArray[Any]]:
    """Ragged tables, one after the other, as one table.

    Parameters
    ----------
    tables : list of (offsets, values)
        Each table's (N_k + 1,) offsets and its items.
    empty : array
        The values of no table (its dtype and trailing shape), returned when
        ``tables`` is empty.

    Returns
    -------
    offsets : (sum(N_k) + 1,) array of int
    values : array

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.csr import join
    >>> first = (np.array([0, 2]), np.array([1, 2]))  # one run of two items
    >>> second = (np.array([0, 1]), np.array([3]))  # one run of one
    >>> rows, items = join([first, second], np.zeros(0, dtype=np.int64))
    >>> rows.tolist(), items.tolist()
    ([0, 2, 3], [1, 2, 3])
    """
    if not tables:
        return np.zeros(1, dtype=np.int64), empty
    counts = np.concatenate([np.diff(bounds) for bounds, _ in tables])
    return offsets(counts), np.concatenate([values for _, values in tables])


def made_in_parts(
    make: Callable[[int, int], tuple[IntArray, NDArray[Any]]],
    start: int,
    stop: int,
    parts: int,
    threads: int,
    empty: NDArray[Any],
) -> tuple[IntArray, NDArray[Any]]:
    """The ragged table of runs [start, stop), made in ``parts`` spans of runs on threads.

    For kernels that release the GIL and grow their output as they go, so
    that no one table can be laid out before them: each span's table is
    ``make(low, high)``, its runs [low, high); with more than one span, they
    are made on a pool of ``threads`` threads (more spans than threads even
    out spans of unequal cost) and joined in order (:func:`join`).

    Parameters
    ----------
    make : callable
        ``make(low, high)`` -> (offsets (high - low + 1,), values).
    start, stop : int
        The runs to make.
    parts : int
        Spans of about equal runs, >= 1.
    threads : int
        Threads to make them on, >= 1.
    empty : array
        As :func:`join`.

    Returns
    -------
    offsets : (stop - start + 1,) array of int
    values : array

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.csr import made_in_parts
    >>> def make(low, high):  # run k holds k copies of k
    ...     counts = np.arange(low, high)
    ...     return offsets(counts), np.repeat(counts, counts)
    >>> rows, items = made_in_parts(make, 0, 4, 3, 2, np.zeros(0, dtype=np.int64))
    >>> rows.tolist(), items.tolist()
    ([0, 0, 1, 3, 6], [1, 2, 2, 3, 3, 3])
    """
    bounds = np.linspace(start, stop, parts + 1).astype(np.int64)
    spans = list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
    if len(spans) == 1:
        return make(*spans[0])
    from concurrent.futures import ThreadPoolExecutor  # here: an FLS alone makes one span

    with ThreadPoolExecutor(threads) as pool:
        tables = list(pool.map(lambda span: make(*span), spans))
    return join(tables, empty)


#: How :func:`narrowed` keeps indices that fit: 32 bits, half of numpy's default.
NARROW = np.int32


def narrowed(indices: IntArray) -> NDArray[np.int32] | IntArray:
    """``indices`` in 32 bits where every one fits, else as they are.

    For index arrays held as long as a run (a display's 20 M ordered blind
    targets, a graph's 28 M entries' pairs): half the memory. What reads them
    as indices is unchanged; what needs int64 converts the part it reads.

    Parameters
    ----------
    indices : (M,) ndarray of int

    Returns
    -------
    (M,) ndarray of int32, or ``indices`` itself where one is out of its range

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.csr import narrowed
    >>> narrowed(np.array([0, 7])).dtype, narrowed(np.array([0, 2**31])).dtype
    (dtype('int32'), dtype('int64'))
    """
    fits = np.iinfo(NARROW)
    if len(indices) and (indices.min() < fits.min or indices.max() > fits.max):
        return indices
    return indices.astype(NARROW)
