"""Multi-path fusion: disjoint paths, inverse-variance weights, and the fused estimates."""

import numpy as np
import pytest

from swazure_ros.core.avoiding import avoiding_paths
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import SWEET_PATH
from swazure_ros.core.fusion import combine, fuse, inner_nodes
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.graph import make_graph
from swazure_ros.core.path_arrays import paths_from_rows
from swazure_ros.core.sensor import Sensor, SensorNoise
from swazure_ros.files.cloud_files import load_cloud


def stochastic_sensor(sd=0.02, direction_deg=1.0):
    """The published ranges with a seeded scatter and no bias."""
    noise = SensorNoise(
        tracking_cm=(0.0, 30.0),
        mean_error=(0.0, 0.0),
        detection=(1.0, 1.0),
        distance_sd=(sd, sd),
        direction_sd_deg=(direction_deg, direction_deg),
        seed=5,
    )
    return Sensor(6.0, 8.0, 8.0, 30.0, name="scatter", noise=noise)


def test_inner_nodes_leave_out_each_path_s_ends():
    paths = paths_from_rows(3, {0: [4, 5, 6, 7], 2: [1, 9]})
    offsets, nodes = inner_nodes(paths)
    assert offsets.tolist() == [0, 2, 2, 2] and nodes.tolist() == [5, 6]


def test_avoiding_paths_go_round_the_avoided_nodes_or_are_not_found():
    # A square 0-1-3 / 0-2-3 (2-3 dearer) and a long way 0-4-5-3.
    edges = [(0, 1, 6.0), (1, 3, 6.0), (0, 2, 6.0), (2, 3, 7.0), (0, 4, 7), (4, 5, 7), (5, 3, 7)]
    first, second, weight = zip(*edges)
    graph = make_graph(6, first, second, weight)
    paths = avoiding_paths(
        graph, [0, 0, 0], [3, 3, 3], "shortest-length", [0, 0, 1, 4], [1, 1, 2, 4]
    )
    assert [paths.path(m) for m in range(3)] == [[0, 1, 3], [0, 2, 3], []]
    assert paths.length[1] == 13.0 and np.isnan(paths.length[2])


def test_combine_weighs_by_inverse_variance_or_by_the_bound():
    vectors = np.array([[[1.0, 0, 0]], [[2.0, 0, 0]]])  # two estimates of one pair
    fused, sd = combine(stochastic_sensor(), vectors, np.array([[1.0], [3.0]]))
    np.testing.assert_allclose(fused, [[(1 + 2 / 3) / (4 / 3), 0, 0]])
    np.testing.assert_allclose(sd, [np.sqrt(3 / 4)])
    published = Sensor(6.0, 8.0, 8.0, 30.0, (0.0018, -0.0275, 0.1156))
    fused, bound = combine(published, vectors, np.array([[1.0], [2.0]]))
    np.testing.assert_allclose(fused, [[(1 + 2 / 4) / 1.25, 0, 0]])
    np.testing.assert_allclose(bound, [(1 + 2 / 4) / 1.25])
    # A pair with one path keeps it.
    one, alone = combine(stochastic_sensor(), vectors, np.array([[1.0], [np.nan]]))
    np.testing.assert_allclose(one, [[1.0, 0, 0]])
    np.testing.assert_allclose(alone, [1.0])


def test_fusing_disjoint_sweet_paths_cuts_a_stochastic_sensor_s_error():
    # At beta 0.3 every blind pair of this torus has a sweet path, most of them several.
    swarm = make_swarm(load_cloud("torus:120").points * 1.6, beta=0.3)
    plain = evaluate(swarm, stochastic_sensor(), "shortest-length")
    fused = fuse(plain, 3)
    several = fused.pairs.fused_paths >= 2
    assert several.sum() > 1000 and fused.pairs.fused_paths.max() == 3
    sweet = plain.pairs.status == SWEET_PATH
    assert (fused.pairs.fused_paths[~sweet] <= 1).all()
    # Pairs with one path keep their estimate; the others' mean error drops.
    alone = sweet & ~several
    np.testing.assert_array_equal(fused.pairs.estimate[alone], plain.pairs.estimate[alone])
    before = plain.pairs.distance_error[several].mean()
    after = fused.pairs.distance_error[several].mean()
    assert after < 0.85 * before
    assert fused.summary.fusion.pairs_fused == several.sum()
    assert (fused.pairs.predicted_error[several] < plain.pairs.predicted_error[several]).all()


def test_fusion_needs_a_path():
    swarm = make_swarm(load_cloud("torus:120").points * 1.6, beta=0.5)
    with pytest.raises(ValueError, match="at least one path"):
        fuse(evaluate(swarm, stochastic_sensor(), "shortest-length"), 0)
