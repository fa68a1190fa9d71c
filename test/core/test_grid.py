"""The grid's nearest-neighbour search: the bits scipy's k-d tree gave, on awkward clouds."""

from __future__ import annotations

import numpy as np
import pytest

RNG = np.random.default_rng(7)
#: Clouds where a ring search could go wrong: ties (a lattice), duplicates, gaps that
#: grow along a line, a flat sheet, two far points, a dense clump beside a sparse shell.
CLOUDS = {
    "lattice": np.stack(np.meshgrid(*[np.arange(9.0)] * 3), -1).reshape(-1, 3) * 0.37,
    "duplicates": np.repeat(RNG.normal(size=(150, 3)), 2, axis=0),
    "growing gaps": np.c_[np.arange(400.0) ** 1.5, np.zeros(400), np.zeros(400)],
    "sheet": np.c_[RNG.random((900, 2)) * 40, np.zeros(900)],
    "two": np.array([[0.0, 0.0, 0.0], [1e-7, 2.0, 3.0]]),
    "clump and shell": np.concatenate(
        [RNG.normal(size=(500, 3)) * 1e-3, RNG.normal(size=(300, 3)) * 1e3]
    ),
    "random": RNG.normal(size=(3000, 3)) * 7,
}


@pytest.mark.parametrize("name", sorted(CLOUDS))
def test_nearest_neighbours_are_the_k_d_trees_distances_bit_for_bit(name):
    from scipy.spatial import cKDTree

    from swazure_ros.core.grid import nearest_neighbours

    points = CLOUDS[name]
    distance, index = nearest_neighbours(points)
    expected, _ = cKDTree(points).query(points, k=2)
    assert distance.tobytes() == expected[:, 1].tobytes()
    # The index is a point at that distance, never the point itself.
    assert not np.any(index == np.arange(len(points)))
    np.testing.assert_array_equal(np.linalg.norm(points - points[index], axis=1) > 0, distance > 0)


def test_a_tie_goes_to_the_lower_index():
    from swazure_ros.core.grid import nearest_neighbours

    _, index = nearest_neighbours(np.array([[0.0, 0, 0], [1, 0, 0], [-1, 0, 0], [0, 5, 0]]))
    assert index.tolist() == [1, 0, 0, 0]


@pytest.mark.parametrize("name", ["lattice", "sheet", "random"])
def test_a_balls_points_are_those_within_its_reach_boundary_included(name):
    from swazure_ros.core.grid import build_grid, scan_ball

    points = CLOUDS[name]
    grid = build_grid(points, 0.1)
    out = np.empty(len(points), dtype=np.int64)
    # Centres on points (a lattice's neighbours lie exactly at the reach) and between them.
    for centre in [points[0], points[len(points) // 2], points[:3].mean(axis=0)]:
        for reach in (0.37, 1.0, 5.0):
            count = scan_ball(points, grid, *centre.tolist(), reach, out)
            gaps = points - centre
            expected = np.flatnonzero((gaps * gaps).sum(axis=1) <= reach * reach)
            assert sorted(out[:count].tolist()) == expected.tolist()


def test_a_balls_cells_are_clipped_to_the_grid_and_empty_where_the_ball_misses_it():
    from swazure_ros.core.grid import ball_cells, grid_of

    # Cells of 1 cm from the lower point: the points span cells 0..3 on x, 0 on y and z.
    grid = grid_of(np.array([[0.0, 0.0, 0.0], [3.5, 0.0, 0.0]]), 1.0)
    assert grid.shape.tolist() == [4, 1, 1]
    # A ball at 2.0 of reach 0.6 spans x 1.4..2.6: cells 1 and 2; y and z clip to cell 0.
    assert ball_cells(grid, 2.0, 0.0, 0.0, 0.6) == (1, 0, 0, 2, 0, 0)
    # Past the last cell on x, the box is empty there (its first cell after its last).
    lo0, _, _, hi0, _, _ = ball_cells(grid, 9.0, 0.0, 0.0, 1.0)
    assert lo0 > hi0
