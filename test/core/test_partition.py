"""core.partition: k-d regions of near-equal size, compact, the same every time."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.partition import kd_split


def line(n: int) -> np.ndarray:
    return np.column_stack([np.arange(n, dtype=float), np.zeros(n), np.zeros(n)])


def test_a_line_splits_into_consecutive_runs():
    assert [part.tolist() for part in kd_split(line(7), 3)] == [[0, 1, 2], [3, 4], [5, 6]]


def test_the_widest_axis_is_cut_first():
    # Two clusters far apart along y, each spread a little along x.
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 50, 0], [1, 50, 0]], dtype=float)
    assert [part.tolist() for part in kd_split(points, 2)] == [[0, 1], [2, 3]]


@pytest.mark.parametrize("parts", [1, 2, 3, 4, 5, 7])
def test_every_row_once_and_sizes_differ_by_at_most_one(parts):
    points = np.random.default_rng(3).uniform(0, 100, (101, 3))
    split = kd_split(points, parts)
    assert len(split) == parts
    assert sorted(np.concatenate(split).tolist()) == list(range(101))
    sizes = [len(part) for part in split]
    assert max(sizes) - min(sizes) <= 1


def test_regions_are_compact():
    # Four regions of a cube's points: each one's box is far smaller than the cube.
    points = np.random.default_rng(4).uniform(0, 100, (400, 3))
    for part in kd_split(points, 4):
        assert np.prod(np.ptp(points[part], axis=0)) < 0.4 * 100**3


def test_ties_keep_the_rows_order():
    points = np.zeros((4, 3))
    assert [part.tolist() for part in kd_split(points, 2)] == [[0, 1], [2, 3]]


def test_more_parts_than_points_is_refused():
    with pytest.raises(ValueError, match="3 parts for 2 points"):
        kd_split(line(2), 3)
