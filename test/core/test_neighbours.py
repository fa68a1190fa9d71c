import numpy as np
import pytest

from swazure_ros.core.geometry import centre_distance, make_swarm
from swazure_ros.core.neighbours import neighbour_pairs


def random_swarm(seed, count=400, extent=60.0):
    rng = np.random.default_rng(seed)
    return make_swarm(rng.uniform(0, extent, size=(count, 3)), radius=0.5)


@pytest.mark.parametrize("seed", [1, 2])
def test_neighbour_pairs_are_every_pair_within_reach_sorted(sensor, seed):
    swarm = random_swarm(seed)
    pairs = neighbour_pairs(swarm, sensor)
    first, second = np.triu_indices(swarm.size, k=1)
    tracking = centre_distance(swarm.points, first, second) - 2 * swarm.radius
    within = tracking < sensor.decaying_max
    np.testing.assert_array_equal(pairs.first, first[within])
    np.testing.assert_array_equal(pairs.second, second[within])
    np.testing.assert_array_equal(pairs.tracking, tracking[within])
    np.testing.assert_array_equal(pairs.range_class, sensor.classify(tracking[within]))


def test_index_finds_a_pair_in_either_order_and_minus_one_for_none(sensor):
    swarm = random_swarm(3)
    pairs = neighbour_pairs(swarm, sensor)
    some = np.arange(0, len(pairs), 97)
    np.testing.assert_array_equal(pairs.index(pairs.first[some], pairs.second[some]), some)
    np.testing.assert_array_equal(pairs.index(pairs.second[some], pairs.first[some]), some)
    far = np.flatnonzero(
        centre_distance(swarm.points, np.zeros(swarm.size, int), np.arange(swarm.size))
        - 2 * swarm.radius
        >= sensor.decaying_max
    )
    assert (pairs.index(np.zeros(len(far), int), far) == -1).all()
    assert pairs.index([4], [4]).tolist() == [-1]
