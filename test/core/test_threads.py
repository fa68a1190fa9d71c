"""core/threads.py: work on threads, its results taken in order, a bounded number ahead."""

import threading
import time
from concurrent.futures import ThreadPoolExecutor

import pytest

from swazure_ros.core.threads import in_order

from ..waits import PATIENCE


def test_results_come_in_the_items_order_whichever_call_ends_first():
    # The first item's call is the slowest: later ones end before it.
    def slow_first(item):
        time.sleep(0.2 if item == 0 else 0.0)
        return item * 10

    with ThreadPoolExecutor(3) as pool:
        assert list(in_order(pool, slow_first, range(6), at_once=3)) == [0, 10, 20, 30, 40, 50]


@pytest.mark.parametrize("at_once", [1, 2, 3])
def test_no_more_calls_run_than_asked_and_that_many_do(at_once):
    lock, running, most = threading.Lock(), [0], [0]
    # The first calls wait for each other: they break the barrier unless that many run.
    together = threading.Barrier(at_once, timeout=PATIENCE)

    def call(item):
        with lock:
            running[0] += 1
            most[0] = max(most[0], running[0])
        if item < at_once:
            together.wait()
        with lock:
            running[0] -= 1
        return item

    with ThreadPoolExecutor(4) as pool:
        assert list(in_order(pool, call, range(8), at_once)) == list(range(8))
    assert most[0] == at_once


def test_items_are_read_only_as_calls_are_needed():
    read = []

    def items():
        for item in range(10):
            read.append(item)
            yield item

    with ThreadPoolExecutor(2) as pool:
        results = in_order(pool, lambda item: item, items(), at_once=2)
        assert next(results) == 0
        assert read == [0, 1]  # the first result waited for; one more running


def test_a_call_s_error_is_raised_in_its_place():
    def call(item):
        if item == 2:
            raise ValueError("item 2")
        return item

    got = []
    with ThreadPoolExecutor(2) as pool, pytest.raises(ValueError, match="item 2"):
        for result in in_order(pool, call, range(5), at_once=2):
            got.append(result)
    assert got == [0, 1]


def test_at_least_one_call_at_a_time():
    with ThreadPoolExecutor(1) as pool, pytest.raises(ValueError, match="at least one"):
        list(in_order(pool, str, range(3), at_once=0))
