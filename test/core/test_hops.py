"""The hops of paths on the hand-built scene: their pairs, measured sums, classes, obstruction."""

import numpy as np
import pytest

from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.hop_errors import hop_error, measured_vectors
from swazure_ros.core.hops import (
    estimates,
    hop_classes,
    hop_table,
    path_obstruction,
    summed_hop_errors,
)
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.path_arrays import paths_from_rows

from ..conftest import SCENE, A, B, C, D, K, scene


def pair_ends(hood, index):
    return [(int(hood.pairs.first[i]), int(hood.pairs.second[i])) for i in index]


def test_the_hop_table_lists_every_hop_in_path_order_with_its_pair(sensor):
    hood = neighbourhood(scene(A, B, C), sensor)
    hops = hop_table(hood, paths_from_rows(3, {0: [A, B, C], 2: [C, B]}))
    assert hops.size == 3
    assert hops.path.tolist() == [0, 0, 2]
    assert (hops.start.tolist(), hops.end.tolist()) == ([A, B, C], [B, C, B])
    assert pair_ends(hood, hops.pair) == [(A, B), (B, C), (B, C)]
    assert (hops.slot >= 0).all()  # sweet hops in sight: edges of SD_vis


def test_a_path_s_estimate_sums_its_measured_hops_from_the_source_outwards(sensor):
    swarm = scene(A, B, C)
    hood = neighbourhood(swarm, sensor)
    paths = paths_from_rows(2, {0: [A, B, C]})
    estimate, sweet, decaying = estimates(hood, paths)
    vectors = measured_vectors(sensor, swarm.points, 0.5, [A, B], [B, C])
    np.testing.assert_array_equal(estimate[0], vectors[0] + vectors[1])
    assert np.isnan(estimate[1]).all()
    assert (sweet.tolist(), decaying.tolist()) == ([2, 0], [0, 0])
    tracking = hood.pairs.tracking[hop_table(hood, paths).pair]
    np.testing.assert_array_equal(
        summed_hop_errors(hood, paths), [hop_error(sensor, tracking, 0.5).sum(), np.nan]
    )


def test_a_hop_out_of_sight_is_measured_and_classed_all_the_same(sensor):
    swarm = scene(A, B, C, K, D)
    hood = neighbourhood(swarm, sensor)
    paths = paths_from_rows(2, {0: [A, B], 1: [A, D, C]})  # K blocks A-B
    hops = hop_table(hood, paths)
    assert hops.slot.tolist()[0] == -1 and (hops.slot[1:] >= 0).all()
    estimate, _, _ = estimates(hood, paths, hops)
    np.testing.assert_array_equal(
        estimate[0], measured_vectors(sensor, swarm.points, 0.5, [A], [B])[0]
    )
    assert [row.tolist() for row in hop_classes(hood, paths, hops)] == [[1, 0], [0, 2]]


def test_a_hop_between_flss_out_of_each_other_s_reach_is_refused(sensor):
    far = make_swarm(np.vstack([SCENE[[A, B]], [[100.0, 0.0, 0.0]]]), radius=0.5)
    with pytest.raises(ValueError, match="out of each other's reach"):
        hop_table(neighbourhood(far, sensor), paths_from_rows(1, {0: [0, 2]}))


def test_path_obstruction_counts_each_path_s_distinct_obstructing_flss(sensor):
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    paths = paths_from_rows(3, {0: [A, B, C], 1: [C, B], 2: [C, B, A]})
    blocked, obstructing = path_obstruction(hood, hood.sweet_all, paths)
    assert blocked.tolist() == [True, False, True]
    assert obstructing.tolist() == [1, 0, 1]  # K alone


def test_path_obstruction_refuses_a_hop_its_graph_does_not_hold(sensor):
    hood = neighbourhood(scene(A, B, C, K, D), sensor)
    with pytest.raises(ValueError, match="does not join"):
        path_obstruction(hood, hood.sweet_all, paths_from_rows(1, {0: [A, D, C]}))
