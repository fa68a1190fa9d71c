"""Line of sight by fans: the same judgements as the scan, a shared first end at a time."""

import numpy as np
import pytest

from swazure_ros.core import sight
from swazure_ros.core.fans import DIRECTION_CELL, FEWEST_FANNED, NEAR, obstructed_fans
from swazure_ros.core.grid import build_grid
from swazure_ros.core.sight import obstructed

from .test_sight import brute_force, random_segments


def by_first(first, second):
    order = np.argsort(first, kind="stable")
    return first[order], second[order]


def test_fans_match_brute_force_on_random_swarms():
    points, radius, first, second = random_segments(17)
    first, second = by_first(first, second)
    result = obstructed_fans(points, radius, first, second, fewest=1)  # every end fanned
    assert result.tolist() == brute_force(points, radius, first, second)


def test_fans_match_the_scan_where_each_fls_starts_many_long_segments():
    # A display's decaying pairs: 1,500 FLSs on a shell of 12 cm, every pair up to 30 cm
    # from the first 60 of them, blocked near their start, far along or not at all.
    rng = np.random.default_rng(5)
    direction = rng.normal(size=(1500, 3))
    points = 12.0 * direction / np.linalg.norm(direction, axis=1)[:, None]
    first, second = np.nonzero(np.linalg.norm(points[:60, None] - points[None], axis=2) < 30.0)
    keep = first != second
    first, second = first[keep], second[keep]
    result = obstructed_fans(points, 0.3, first, second)
    expected = obstructed(points, 0.3, first, second)
    assert 0.05 < expected.mean() < 0.95  # both kinds, many of each
    assert np.array_equal(result, expected)


def fanned_and_scanned():
    """The first 60 FLSs of a shell start over a thousand segments each and are fanned;
    20 more start a handful each, too few to pay for a map, and are scanned."""
    rng = np.random.default_rng(6)
    direction = rng.normal(size=(1500, 3))
    points = 12.0 * direction / np.linalg.norm(direction, axis=1)[:, None]
    first, second = np.nonzero(np.linalg.norm(points[:80, None] - points[None], axis=2) < 30.0)
    keep = (first != second) & ((first < 60) | (second % 200 == 0))
    return points, first[keep], second[keep]


def test_ends_with_few_segments_are_scanned_and_judged_the_same():
    points, first, second = fanned_and_scanned()
    counts = np.bincount(first)
    assert counts[:60].min() >= FEWEST_FANNED > counts[60:80].max() > 0
    expected = obstructed(points, 0.3, first, second)
    assert 0.05 < expected.mean() < 0.95
    assert np.array_equal(obstructed_fans(points, 0.3, first, second), expected)
    few = first >= 60
    assert np.array_equal(obstructed_fans(points, 0.3, first[few], second[few]), expected[few])


def test_an_fls_far_along_within_r_of_a_segment_blocks_it_across_a_direction_cell():
    # A-B points just past a border of the grid over directions (y = 0.2 + 1e-4), and K,
    # 15 cm along and r off the segment on the other side of that border, has its own
    # direction in the next cell down: only the spread of its directions finds it.
    radius = 0.3
    rise = 0.2 + 1e-4
    unit = np.array([np.sqrt(1.0 - rise**2), rise, 0.0])
    normal = np.array([-rise, np.sqrt(1.0 - rise**2), 0.0])
    for off, blocked in ((radius * (1.0 - 1e-9), True), (radius * (1.0 + 1e-6), False)):
        points = np.array([[0.0, 0, 0], 20.0 * unit, 15.0 * unit - off * normal])
        own = points[2] / np.linalg.norm(points[2])
        assert np.floor((own[1] + 1.0) / DIRECTION_CELL) < np.floor((rise + 1.0) / DIRECTION_CELL)
        assert np.linalg.norm(points[2]) > NEAR * radius  # mapped, not in the near list
        assert obstructed_fans(points, radius, [0], [1], fewest=1).tolist() == [blocked]
        assert obstructed(points, radius, [0], [1]).tolist() == [blocked]


def test_an_fls_close_to_the_shared_end_blocks_what_passes_within_r():
    # Within NEAR r of A: tried against every segment from A.
    points = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0], [0.9, 0.3, 0]])
    assert np.linalg.norm(points[3]) < NEAR * 0.3
    assert obstructed_fans(points, 0.3, [0, 0], [1, 2], fewest=1).tolist() == [True, False]


def test_segments_not_grouped_by_their_first_end_are_refused():
    points = np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0]])
    with pytest.raises(ValueError, match="sorted"):
        obstructed_fans(points, 0.3, [1, 0], [2, 2])


def test_no_segments_judge_nothing():
    assert obstructed_fans(np.zeros((2, 3)), 0.3, [], []).tolist() == []


def test_the_scanned_ends_use_the_grid_given_and_build_none(monkeypatch):
    # A display's regions judge thousands of small sets: the swarm's grid is built once.
    points, first, second = fanned_and_scanned()
    expected = obstructed(points, 0.3, first, second)
    grid = build_grid(points, 0.3)

    def refused(*_):
        raise AssertionError("a grid was built though one was given")

    monkeypatch.setattr(sight, "build_grid", refused)
    assert np.array_equal(obstructed_fans(points, 0.3, first, second, grid=grid), expected)
    with pytest.raises(AssertionError, match="a grid was built"):
        obstructed_fans(points, 0.3, first, second)
