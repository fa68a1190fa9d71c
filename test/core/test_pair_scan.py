"""Pairs within reach scanned on a grid are the pairs a brute force finds."""

import numpy as np
import pytest

from swazure_ros.core.grid import grid_of
from swazure_ros.core.pair_scan import counts_within, pairs_within


@pytest.mark.parametrize("cells_per_reach", [0.5, 1.0, 2.0, 3.0])
def test_pairs_within_reach_on_a_grid_of_any_cell_are_the_brute_force_pairs(cells_per_reach):
    rng = np.random.default_rng(11)
    points = rng.uniform(0.0, 60.0, size=(300, 3))
    reach = 9.0
    grid = grid_of(points, reach / cells_per_reach)
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    want_first, want_second = np.nonzero(np.triu(distance <= reach, k=1))
    rows, second = pairs_within(points, reach, grid)
    first = np.repeat(np.arange(len(points)), np.diff(rows))
    np.testing.assert_array_equal(first, want_first)
    np.testing.assert_array_equal(second, want_second)
    assert counts_within(points, reach, grid).tolist() == np.diff(rows).tolist()
    assert 200 < len(second) < 10_000  # some pairs, and far fewer than all of them


def test_pairs_within_reach_and_no_nearer_than_a_least_distance_are_the_brute_force_pairs():
    rng = np.random.default_rng(12)
    points = rng.uniform(0.0, 60.0, size=(300, 3))
    reach, nearest = 9.0, 6.0
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    between = np.triu((distance <= reach) & (distance >= nearest), k=1)
    want_first, want_second = np.nonzero(between)
    rows, second = pairs_within(points, reach, grid_of(points, reach / 2), nearest=nearest)
    first = np.repeat(np.arange(len(points)), np.diff(rows))
    np.testing.assert_array_equal(first, want_first)
    np.testing.assert_array_equal(second, want_second)
    nearer = np.triu(distance < nearest, k=1).sum()
    assert nearer > 100 and len(second) > 100  # pairs left out, and pairs kept
