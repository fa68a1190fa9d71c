"""Rows of ids in a sorted array of distinct ids: every id found where it is, and no other."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.lookup import sorted_rows

#: Every id asked: below, among and above the ids held, so none is left out by its place.
ASKED = np.arange(-3, 14)


def expected(values: list[int], wanted: np.ndarray) -> tuple[list[int], list[bool]]:
    """By hand: an id's row where it is held; elsewhere where it would go, at most the last."""
    rows, found = [], []
    for one in wanted.tolist():
        where = sum(value < one for value in values)
        rows.append(min(where, max(len(values) - 1, 0)))
        found.append(one in values)
    return rows, found


@pytest.mark.parametrize(
    "values",
    [[], [0], [0, 1, 2, 3, 4], [0, 1, 2, 4, 5], [1, 2, 3], [2, 5, 9], [0, 3, 11]],
    ids=["none", "one", "every id from 0", "a gap", "from 1", "spread", "0 and spread"],
)
def test_each_id_is_found_at_its_row_and_one_not_held_is_not(values):
    rows, found = sorted_rows(np.array(values, dtype=np.int64), ASKED)
    assert (rows.tolist(), found.tolist()) == expected(values, ASKED)
    assert rows.dtype == np.int64 and found.dtype == bool


def test_ids_from_the_wire_and_of_any_shape_are_looked_up_flat():
    values = np.arange(6, dtype=np.int64)  # every id from 0: each its own row
    wanted = np.array([[5, 0], [2, 7]], dtype=np.uint32)
    rows, found = sorted_rows(values, wanted)
    assert rows.tolist() == [5, 0, 2, 5] and found.tolist() == [True, True, True, False]
    # The same ids held with a gap take the search, and agree where the ids are held.
    gapped = np.array([0, 1, 2, 5, 6, 7], dtype=np.int64)
    rows, found = sorted_rows(gapped, wanted)
    assert gapped[rows[found]].tolist() == [5, 0, 2, 7]
