"""Ragged tables laid out flat: the runs of one taken as a table of their own."""

from __future__ import annotations

import numpy as np

from swazure_ros.core.csr import narrowed, span, take

# Three paths: (4, 5), (), (6, 7, 8).
BOUNDS = np.array([0, 2, 2, 5])
IDS = np.array([4, 5, 6, 7, 8])


def test_a_span_of_runs_is_the_table_those_runs_make_taken_in_order():
    for low in range(4):
        for high in range(low, 4):
            offsets, ids = span(BOUNDS, IDS, low, high)
            expected_offsets, expected_ids = take(BOUNDS, IDS, np.arange(low, high))
            np.testing.assert_array_equal(offsets, expected_offsets)
            np.testing.assert_array_equal(ids, expected_ids)


def test_a_span_s_items_are_a_view_and_rows_of_several_values_stay_whole():
    _, ids = span(BOUNDS, IDS, 2, 3)
    assert np.shares_memory(ids, IDS) and ids.tolist() == [6, 7, 8]
    vectors = np.arange(15.0).reshape(5, 3)
    offsets, rows = span(BOUNDS, vectors, 0, 1)
    assert offsets.tolist() == [0, 2] and rows.tolist() == [[0, 1, 2], [3, 4, 5]]


def test_a_table_made_in_parts_on_threads_is_the_table_made_whole():
    import threading

    from swazure_ros.core.csr import made_in_parts, offsets

    made_on = set()

    def make(low, high):  # run k: the ids k, k + 1, ..., k + (k % 4) - 1
        made_on.add(threading.current_thread().name)
        counts = np.arange(low, high) % 4
        starts = np.arange(low, high)
        return offsets(counts), np.concatenate(
            [np.arange(start, start + count) for start, count in zip(starts, counts)] + [[]]
        ).astype(np.int64)

    empty = np.zeros(0, dtype=np.int64)
    whole_offsets, whole_ids = make(3, 40)
    for parts in (1, 2, 5, 37):
        made_on.clear()
        rows, ids = made_in_parts(make, 3, 40, parts, 2, empty)
        np.testing.assert_array_equal(rows, whole_offsets)
        np.testing.assert_array_equal(ids, whole_ids)
        # One part is made where it is asked for; several on the pool's threads.
        assert (threading.current_thread().name in made_on) == (parts == 1)


def test_indices_that_fit_are_narrowed_to_32_bits_and_others_kept_as_they_are():
    fitting = np.array([0, 5, 2**31 - 1, -(2**31)])
    assert narrowed(fitting).dtype == np.int32
    assert narrowed(fitting).tolist() == fitting.tolist()
    for beyond in (np.array([3, 2**31]), np.array([-(2**31) - 1, 0])):
        assert narrowed(beyond) is beyond
    assert narrowed(np.array([], dtype=np.int64)).dtype == np.int32
