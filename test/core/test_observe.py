"""What each FLS observes, laid out per FLS (core.observe)."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core import observe
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.observe import observations
from swazure_ros.core.sensor import DECAYING, Sensor
from swazure_ros.sim.world import WorldSpec

from .fits import stochastic_sensor

COLUMNS = ("indptr", "other", "range_class", "visible", "vector", "tracking", "distance")


@pytest.mark.parametrize("owners", [None, "every third"])
def test_camera_readings_made_block_by_block_are_those_made_at_once(monkeypatch, owners):
    # A stochastic sensor: each pair's reading has its own seeded draw, wherever it is made.
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    hood = neighbourhood(world.swarm, stochastic_sensor(mean_error=0.03))
    hosted = None if owners is None else np.arange(0, world.swarm.size, 3)
    whole = observations(hood, hosted)
    measured = int(whole.measured.sum())
    assert measured > 300  # so about 4 blocks or more
    monkeypatch.setattr(observe, "CAMERA_BLOCK", 97)  # many blocks, the last one short
    blocks = observations(hood, hosted)
    for name in COLUMNS:
        np.testing.assert_array_equal(getattr(blocks, name), getattr(whole, name), err_msg=name)
    if hosted is not None:  # only the hosted FLSs' rows
        rows = np.diff(whole.indptr)
        assert rows[hosted].sum() == len(whole.other) and rows.sum() == len(whole.other)


def test_a_decaying_neighbour_out_of_sight_is_no_row_and_one_in_sight_is():
    # A, B, C on a line 7 cm apart, D 14 cm from A across: A-C and A-D are decaying, and
    # B stands between A and C. Sensor: blind below 6 cm, sweet to 8, decaying to 30.
    swarm = make_swarm(np.array([[0.0, 0, 0], [7, 0, 0], [14, 0, 0], [0, 14, 0]]), radius=0.5)
    hood = neighbourhood(swarm, Sensor(6.0, 8.0, 8.0, 30.0))
    pairs = hood.pairs
    a_c = np.flatnonzero((pairs.first == 0) & (pairs.second == 2))
    a_d = np.flatnonzero((pairs.first == 0) & (pairs.second == 3))
    assert pairs.range_class[a_c].tolist() == pairs.range_class[a_d].tolist() == [DECAYING]
    assert not hood.visible[a_c].any() and hood.visible[a_d].all()  # the pairs keep both
    seen = observations(hood)
    # A senses B (sweet) and D (decaying, in sight); C neither by radio nor by camera.
    assert seen.other[seen.rows(0)].tolist() == [1, 3]
    assert seen.other[seen.rows(2)].tolist() == [1, 3]
    assert seen.other[seen.rows(1)].tolist() == [0, 2, 3]
    assert seen.visible.all()


@pytest.mark.parametrize("a_point_removed", [False, True])
def test_an_fls_s_view_holds_the_world_s_rows_in_place_and_reads_as_they_do(a_point_removed):
    # Every FLS of a process keeps its view for a whole run: a copy of its rows would be
    # 32 B a row, over a gigabyte for a share of a display. A, B, C, D as above; with a
    # point 0.01 cm from D first, one of the two is removed and the ids are not the indices.
    points = [[0.0, 0, 0], [7, 0, 0], [14, 0, 0], [0, 14, 0]]
    swarm = make_swarm(np.array([[0, 14.01, 0]] * a_point_removed + points), radius=0.5)
    ids = swarm.cloud_index
    assert swarm.size == 4 and np.array_equal(ids, np.arange(4)) != a_point_removed
    seen = observations(neighbourhood(swarm, Sensor(6.0, 8.0, 8.0, 30.0)))
    assert seen.measured.sum() == 10  # A-B, B-C, A-D, B-D, C-D, both ways
    for fls in range(swarm.size):
        view = observe.local_view(seen, ids, fls)
        rows = seen.rows(fls)
        assert view.fls_id == ids[fls]
        assert view.other.tolist() == ids[seen.other[rows]].tolist()
        np.testing.assert_array_equal(view.vector, seen.vector_at(rows))
        np.testing.assert_array_equal(view.read, seen.measured_in(rows))
        assert np.isfinite(view.vector_at(view.read)).all()
        for name in ("range_class", "visible", "distance", "reading"):
            assert np.shares_memory(getattr(view, name), getattr(seen, name)), name
        assert view.readings_vector is seen.readings_vector
        # The neighbours' ids are the world's own rows where the ids are the indices.
        assert np.shares_memory(view.other, seen.other) != a_point_removed
