"""Work on threads whose results are taken in order, a few of them ahead.

Compiled kernels and most of numpy let go of the GIL, so two pieces of
work on two threads use two cores where each alone leaves one idle part
of its time. :func:`in_order` keeps a bounded number of them running, so
that memory stays bounded, and hands their results back in the order of
their items, so that what is made of them does not depend on which thread
finished first.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from typing import TypeVar

from . import jit

Item = TypeVar("Item")
Result = TypeVar("Result")


def in_order(
    pool: Executor, function: Callable[[Item], Result], items: Iterable[Item], at_once: int
) -> Iterator[Result]:
    """``function`` of each item, run on ``pool``, at most ``at_once`` at a time, in order.

    Parameters
    ----------
    pool : concurrent.futures.Executor
        Runs the calls.
    function : callable
        Called once with each item.
    items : iterable
        Read as calls are needed: at most ``at_once`` items are read ahead of the
        result last handed back.
    at_once : int
        Calls running or done but not yet handed back, at most; at least 1.

    Yields
    ------
    object
        ``function(item)`` for each item, in the order of ``items``. A call's
        exception is raised where its result would be handed back.

    Raises
    ------
    ValueError
        ``at_once`` below 1.

    Examples
    --------
    >>> from concurrent.futures import ThreadPoolExecutor
    >>> with ThreadPoolExecutor(2) as pool:
    ...     list(in_order(pool, lambda x: x * x, range(5), at_once=2))
    [0, 1, 4, 9, 16]
    """
    if at_once < 1:
        raise ValueError(f"at least one call at a time, got {at_once}")
    running: deque[Future[Result]] = deque()
    for item in items:
        running.append(pool.submit(function, item))
        if len(running) >= at_once:
            yield running.popleft().result()
    while running:
        yield running.popleft().result()


def kernel_threads(count: int) -> int:
    """How many pieces of work that start parallel kernels may run at once.

    Parameters
    ----------
    count : int
        The pieces wanted at once.

    Returns
    -------
    int
        ``count`` where numba's threading layer lets several threads start
        parallel kernels (:func:`.jit.concurrent_kernels`), else 1.
    """
    return count if jit.concurrent_kernels() else 1


def side_by_side(
    function: Callable[[Item], Result], items: Iterable[Item], count: int, name: str
) -> Iterator[Result]:
    """:func:`in_order` on a pool of its own of :func:`kernel_threads` (``count``) threads.

    Parameters
    ----------
    function : callable
        Called once with each item; it may start parallel kernels.
    items : iterable
        Read as calls are needed.
    count : int
        The calls wanted at once, where numba's threading layer allows them.
    name : str
        The pool's threads' name prefix.

    Yields
    ------
    object
        ``function(item)`` for each item, in the order of ``items``.
    """
    threads = kernel_threads(count)
    with ThreadPoolExecutor(threads, thread_name_prefix=name) as pool:
        yield from in_order(pool, function, items, threads)
