"""The summaries' rows (core.metric_rows): ranks and ties."""

import pytest

from swazure_ros.core.metric_rows import rank


def test_rank_puts_the_best_first_and_groups_ties():
    assert rank([3.0, 1.0, None, 2.0], "lower") == ((1,), (3,), (0,))
    assert rank([3.0, 1.0, None, 2.0], "higher") == ((0,), (3,), (1,))
    # Within 1e-4 of each other (relative): one group, in the runs' order.
    assert rank([2.0, 1.0, 1.00000001, 5.0], "lower") == ((1, 2), (0,), (3,))
    assert rank([None, None], "lower") == ()


def test_rank_refuses_a_number_without_a_better_direction():
    with pytest.raises(ValueError, match="better must be 'lower' or 'higher'"):
        rank([1.0, 2.0], "neither")
