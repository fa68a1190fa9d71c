import numpy as np
import pytest

from swazure_ros.core.errors import CloudError
from swazure_ros.core.geometry import make_swarm, min_distance, remove_collisions
from swazure_ros.core.neighbours import neighbour_pairs, ordered_blind_pairs
from swazure_ros.core.sensor import BLIND, SWEET

from ..conftest import dataset


def test_radius_is_beta_times_dmin():
    points = np.array([[0, 0, 0], [2, 0, 0], [0, 5, 0]], dtype=float)
    swarm = make_swarm(points, beta=0.25)
    assert swarm.dmin == 2.0
    assert swarm.radius == 0.5
    assert swarm.removed == 0


def test_collisions_remove_one_of_each_close_pair_deterministically():
    # 0-1 and 1-2 are 1 cm apart; with r = 0.6 (2r = 1.2) they collide, 0-2 do not.
    points = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [10, 0, 0]], dtype=float)
    kept = remove_collisions(points, 0.6, seed=7)
    assert np.array_equal(kept, remove_collisions(points, 0.6, seed=7))
    distances = np.linalg.norm(points[kept][:, None] - points[kept][None], axis=-1)
    assert (distances[np.triu_indices(len(kept), 1)] >= 1.2).all()
    assert 3 in kept
    assert kept.tolist() in ([0, 2, 3], [1, 3])


def test_beta_above_half_removes_and_reports():
    points = np.array([[0, 0, 0], [1, 0, 0], [2.5, 0, 0], [10, 0, 0]], dtype=float)
    swarm = make_swarm(points, beta=0.9)  # 2r = 1.8: 0-1 collide, 1-2 collide
    assert swarm.removed >= 1
    assert swarm.removed + swarm.size == 4


@pytest.mark.parametrize("beta", [0.0, -0.1, 1.5, float("nan")])
def test_beta_out_of_range(beta):
    with pytest.raises(CloudError, match="beta must be in"):
        make_swarm([[0, 0, 0], [1, 0, 0]], beta=beta)


def test_duplicate_points():
    with pytest.raises(CloudError, match="duplicate points"):
        make_swarm([[0, 0, 0], [1, 0, 0], [1, 0, 0]], beta=0.5)


def test_tracking_distance_classes(sensor):
    # r = 0.5: t = d - 1. d = 4 blind, d = 7.5 sweet.
    swarm = make_swarm([[0, 0, 0], [4, 0, 0], [0, 7.5, 0]], radius=0.5)
    pairs = neighbour_pairs(swarm, sensor)
    classes = dict(zip(zip(pairs.first.tolist(), pairs.second.tolist()), pairs.range_class))
    assert classes[(0, 1)] == BLIND
    assert classes[(0, 2)] == SWEET
    source, target = ordered_blind_pairs(pairs)
    assert list(zip(source.tolist(), target.tolist())) == [(0, 1), (1, 0)]


def test_min_distance():
    assert min_distance([[0, 0, 0], [3, 4, 0], [10, 0, 0]]) == 5.0


def test_chess_piece_check_values(sensor):
    from swazure_ros.files.cloud_files import load_cloud

    swarm = make_swarm(load_cloud(dataset("chess_408.xyz")).points, beta=0.5)
    pairs = neighbour_pairs(swarm, sensor)
    assert len(ordered_blind_pairs(pairs)[0]) == 105_778
    assert pairs.kissing() == 9
    assert int((pairs.tracking == 0).sum()) == 1


@pytest.mark.parametrize("shape", ["torus", "helix:300", "sphere:200"])
def test_a_small_cloud_searched_pair_by_pair_gives_the_trees_answers(shape, monkeypatch):
    from swazure_ros.core import geometry
    from swazure_ros.files.cloud_files import load_cloud

    points = load_cloud(shape).points
    assert len(points) <= geometry.SMALL_CLOUD
    by_pairs = geometry.min_distance(points)
    radius = 0.6 * by_pairs  # some points collide
    pairs = {tuple(pair) for pair in geometry.colliding_pairs(points, radius).tolist()}
    monkeypatch.setattr(geometry, "SMALL_CLOUD", 0)  # the k-d tree's search
    assert geometry.min_distance(points) == by_pairs
    assert {tuple(pair) for pair in geometry.colliding_pairs(points, radius).tolist()} == pairs
    assert pairs


def test_centre_distance_gives_the_same_bits_compiled_for_many_pairs_as_with_numpy(monkeypatch):
    from swazure_ros.core import geometry

    rng = np.random.default_rng(3)
    points = rng.normal(size=(500, 3)) * 37.3
    first, second = rng.integers(0, 500, size=(2, 20_000))
    with_numpy = geometry.centre_distance(points, first, second)
    monkeypatch.setattr(geometry, "COMPILED_PAIRS", 1)
    compiled = geometry.centre_distance(points, first, second)
    assert np.array_equal(compiled.view(np.int64), with_numpy.view(np.int64))
    # The order of the sum matters: about one distance in nine differs in its last bit
    # when the three squares are added from x to z.
    offset = points[second] - points[first]
    assert np.allclose(compiled, np.sqrt(np.sum(offset * offset, axis=1)), rtol=1e-15)
