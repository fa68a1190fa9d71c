import numpy as np
import pytest

from swazure_ros.core.paths import make_graph, path_hops, shortest_paths


def graph(edges):
    first, second, weight = zip(*edges)
    return make_graph(max(max(first), max(second)) + 1, first, second, weight)


# 0-1-3 is two hops of 5 (length 10); 0-2-4-3 is three hops of 1 (length 3).
TWO_LONG_OR_THREE_SHORT = [(0, 1, 5.0), (1, 3, 5.0), (0, 2, 1.0), (2, 4, 1.0), (4, 3, 1.0)]


def test_fewest_hops_takes_fewer_edges():
    paths = shortest_paths(graph(TWO_LONG_OR_THREE_SHORT), [0], [3], "fewest-hops")
    assert paths.path(0) == [0, 1, 3]
    assert paths.hops[0] == 2
    assert paths.length[0] == 10.0


def test_shortest_length_takes_smaller_sum():
    paths = shortest_paths(graph(TWO_LONG_OR_THREE_SHORT), [0], [3], "shortest-length")
    assert paths.path(0) == [0, 2, 4, 3]
    assert paths.hops[0] == 3
    assert paths.length[0] == 3.0


def test_fewest_hops_breaks_hop_ties_by_length():
    edges = [(0, 1, 5.0), (1, 3, 5.0), (0, 2, 2.0), (2, 3, 2.0)]
    assert shortest_paths(graph(edges), [0], [3], "fewest-hops").path(0) == [0, 2, 3]


def test_equal_cost_ties_go_to_the_smallest_predecessor():
    # Both 0-1-3 and 0-2-3 have two hops and length 4; node 2 is settled first.
    edges = [(0, 2, 1.0), (2, 3, 3.0), (0, 1, 3.0), (1, 3, 1.0)]
    for policy in ("fewest-hops", "shortest-length"):
        assert shortest_paths(graph(edges), [0], [3], policy).path(0) == [0, 1, 3]


def test_unreachable_target_is_not_found():
    paths = shortest_paths(graph([(0, 1, 1.0), (2, 3, 1.0)]), [0, 0], [1, 3], "fewest-hops")
    assert paths.found.tolist() == [True, False]
    assert paths.path(1) == []


def test_long_paths_beyond_the_parallel_buffer():
    chain = [(node, node + 1, 1.0) for node in range(20)]
    paths = shortest_paths(graph(chain), [0, 0, 3], [20, 2, 17], "shortest-length")
    assert paths.path(0) == list(range(21))
    assert paths.path(1) == [0, 1, 2]
    assert paths.path(2) == list(range(3, 18))
    pair, start, end = path_hops(paths)
    assert len(pair) == 20 + 2 + 14
    assert (end - start == 1).all()


def test_unknown_policy():
    with pytest.raises(ValueError, match="unknown path policy 'widest'"):
        shortest_paths(graph([(0, 1, 1.0)]), [0], [1], "widest")


def test_pairs_must_be_sorted_by_source():
    with pytest.raises(ValueError, match="sorted by source"):
        shortest_paths(graph([(0, 1, 1.0)]), [1, 0], [0, 1], "fewest-hops")


def test_matches_scipy_dijkstra_on_a_random_graph():
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    rng = np.random.default_rng(5)
    size = 200
    first, second = rng.integers(0, size, size=(2, 1200))
    keep = first < second
    pairs = np.unique(np.column_stack([first[keep], second[keep]]), axis=0)
    weight = rng.uniform(1, 3, size=len(pairs))
    g = make_graph(size, pairs[:, 0], pairs[:, 1], weight)
    sources = np.repeat(np.arange(0, size, 7), 5)
    targets = rng.integers(0, size, size=len(sources))
    ok = sources != targets
    sources, targets = sources[ok], targets[ok]
    matrix = coo_matrix((weight, (pairs[:, 0], pairs[:, 1])), shape=(size, size))
    for policy, unweighted in (("shortest-length", False), ("fewest-hops", True)):
        reference = dijkstra(matrix, directed=False, unweighted=unweighted)
        paths = shortest_paths(g, sources, targets, policy)
        expected = reference[sources, targets]
        got = paths.length if policy == "shortest-length" else paths.hops.astype(float)
        np.testing.assert_allclose(got[paths.found], expected[paths.found], rtol=1e-12)
        assert (paths.found == np.isfinite(expected)).all()
