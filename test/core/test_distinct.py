"""Distinct indices and their ranks: by a sort or by marks, the same arrays."""

import numpy as np
import pytest

from swazure_ros.core.distinct import DENSE_SPREAD, distinct_ranks


def expected(values):
    distinct = np.unique(values)
    return distinct.tolist(), np.searchsorted(distinct, values).tolist()


@pytest.mark.parametrize("bound", [40, 40 * DENSE_SPREAD + 1, 10_000])
def test_the_distinct_values_are_sorted_and_each_rank_finds_its_value(bound):
    # 40 indices: a bound of 40 takes the marks, the larger ones the sort.
    values = np.random.default_rng(3).integers(0, min(bound, 25), 40) * (bound // 25 or 1)
    values = np.minimum(values, bound - 1)
    distinct, ranks = distinct_ranks(values, bound)
    assert (distinct.tolist(), ranks.tolist()) == expected(values)
    assert np.array_equal(distinct[ranks], values)
    assert distinct.dtype == ranks.dtype == np.int64


def test_the_marks_and_the_sort_agree_at_the_spread_between_them():
    values = np.array([9, 0, 9, 4, 4, 1])
    at_spread = distinct_ranks(values, DENSE_SPREAD * len(values))
    past_spread = distinct_ranks(values, DENSE_SPREAD * len(values) + 1)
    assert [a.tolist() for a in at_spread] == [b.tolist() for b in past_spread]
    assert (at_spread[0].tolist(), at_spread[1].tolist()) == expected(values)


def test_no_values_give_empty_arrays():
    distinct, ranks = distinct_ranks(np.zeros(0, dtype=np.int64), 5)
    assert distinct.tolist() == ranks.tolist() == []


@pytest.mark.parametrize("values", [[0, 5], [-1, 2]])
def test_an_index_outside_the_bound_is_refused(values):
    with pytest.raises(ValueError, match=r"indices must lie in \[0, 5\)"):
        distinct_ranks(values, 5)
