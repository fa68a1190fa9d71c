"""Ragged tables laid out flat: the runs of one taken as a table of their own."""

from __future__ import annotations

import numpy as np

from swazure_ros.core.csr import span, take

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
