import numpy as np
import pytest

from swazure_ros.core import avoiding as avoiding_module
from swazure_ros.core import graph as graph_module
from swazure_ros.core import jit
from swazure_ros.core import paths as paths_module
from swazure_ros.core.avoiding import avoiding_paths
from swazure_ros.core.graph import make_graph
from swazure_ros.core.path_arrays import path_hops
from swazure_ros.core.paths import shortest_paths


def graph(edges):
    first, second, weight = zip(*edges)
    return make_graph(max(max(first), max(second)) + 1, first, second, weight)


def random_pairs(rng, size, draws):
    """Distinct pairs (first < second) of ``size`` nodes, from ``draws`` random draws."""
    first, second = rng.integers(0, size, size=(2, draws))
    keep = first < second
    return np.unique(np.column_stack([first[keep], second[keep]]), axis=0)


def tied_edges(rng, size, draws, lengths, costs):
    """Random pairs with whole-number lengths and costs drawn from the ranges [low, high):
    many paths of equal cost, so the predecessor rule decides."""
    pairs = random_pairs(rng, size, draws)
    weight = rng.integers(*lengths, size=len(pairs)).astype(float)
    cost = rng.integers(*costs, size=len(pairs)).astype(float)
    return pairs, weight, cost


def assert_same_paths(found, expected):
    for field in ("found", "hops", "offsets", "nodes", "length"):
        np.testing.assert_array_equal(getattr(found, field), getattr(expected, field))


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


def test_least_error_takes_the_smaller_sum_of_edge_costs_and_reports_the_length():
    # 0-1-3: two hops of 6 cm costing 0.09 each; 0-2-3: two hops of 7.2 cm costing 0.08 each.
    edges = [(0, 1, 6.0, 0.09), (1, 3, 6.0, 0.09), (0, 2, 7.2, 0.08), (2, 3, 7.2, 0.08)]
    first, second, weight, cost = zip(*edges)
    costed = make_graph(4, first, second, weight, costs=cost)
    assert shortest_paths(costed, [0], [3], "shortest-length").path(0) == [0, 1, 3]
    paths = shortest_paths(costed, [0], [3], "least-error")
    assert paths.path(0) == [0, 2, 3]
    assert paths.length[0] == 14.4  # tracking distances, not costs


def test_least_error_breaks_cost_ties_by_hops_and_walks_long_paths():
    # A chain of 12 hops costing 1/16 each (0.75 in all, exact in binary) against
    # 0-13-12, two hops of 0.375 (also 0.75), and one dear hop 0-12.
    chain = [(node, node + 1, 6.0, 0.0625) for node in range(12)]
    first, second, weight, cost = zip(*chain, (0, 12, 30.0, 1.0), (0, 13, 6.0, 0.375),
                                       (13, 12, 6.0, 0.375))  # fmt: skip
    costed = make_graph(14, first, second, weight, costs=cost)
    paths = shortest_paths(costed, [0], [12], "least-error")
    assert paths.path(0) == [0, 13, 12]  # equal cost: the fewer hops
    # 0-13-12 dearer now: the chain, past the parallel search's path buffer.
    cheaper = make_graph(14, first, second, weight, costs=[*cost[:-2], 0.5, 0.5])
    assert shortest_paths(cheaper, [0], [12], "least-error").path(0) == list(range(13))
    assert shortest_paths(cheaper, [0], [12], "least-error").length[0] == 72.0


def test_least_error_needs_edge_costs():
    with pytest.raises(ValueError, match="needs a graph with edge costs"):
        shortest_paths(graph([(0, 1, 1.0)]), [0], [1], "least-error")


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


@pytest.mark.parametrize("policy", ["fewest-hops", "shortest-length", "least-error"])
def test_buckets_and_a_heap_pick_the_same_paths_ties_included(monkeypatch, policy):
    import swazure_ros.core.paths as paths_module

    rng = np.random.default_rng(7)
    size = 150
    pairs, weight, cost = tied_edges(rng, size, 900, (2, 6), (1, 4))
    g = make_graph(size, pairs[:, 0], pairs[:, 1], weight, costs=cost)
    sources = np.repeat(np.arange(size), 6)
    targets = rng.integers(0, size, size=len(sources))
    assert paths_module._buckets(g.weights, policy == "fewest-hops")[1] > 0
    buckets = shortest_paths(g, sources, targets, policy)
    monkeypatch.setattr(paths_module, "_MOST_BUCKETS", 0)  # every search takes the heap
    heap = shortest_paths(g, sources, targets, policy)
    assert buckets.found.sum() > 0.8 * len(sources)
    assert_same_paths(buckets, heap)


@pytest.mark.parametrize("policy", ["fewest-hops", "shortest-length", "least-error"])
def test_rows_in_bands_of_length_give_the_paths_of_rows_in_neighbour_order(policy):
    # A search skips the bands it cannot afford; the labels, ties and paths are the same.
    rng = np.random.default_rng(11)
    size = 200
    pairs, weight, cost = tied_edges(rng, size, 2400, (6, 31), (1, 9))
    plain = make_graph(size, pairs[:, 0], pairs[:, 1], weight, costs=cost)
    banded = make_graph(size, pairs[:, 0], pairs[:, 1], weight, costs=cost, bands=6)
    sources = np.repeat(np.arange(size), 4)
    targets = rng.integers(0, size, size=len(sources))
    expected = shortest_paths(plain, sources, targets, policy)
    found = shortest_paths(banded, sources, targets, policy)
    assert expected.found.sum() > 0.8 * len(sources) and expected.hops.max() >= 3
    assert_same_paths(found, expected)


def test_a_target_labelled_early_still_takes_the_smaller_predecessor_at_its_cost():
    # T = 7 is labelled 6 through FLS 5 (bucket 1) before FLS 3 (label 4, bucket 2) offers
    # it 6 as well: the offer equals the dearest target's label and must still be heard,
    # so the tie goes to the smaller FLS as the heap gives it; a dearer offer (FLS 6: 7)
    # is left out.
    g = make_graph(8, [0, 5, 0, 3, 0, 6], [5, 7, 3, 7, 6, 7], [2.0, 4.0, 4.0, 2.0, 4.0, 3.0])
    paths = shortest_paths(g, [0], [7], "shortest-length")
    assert paths.path(0) == [0, 3, 7] and paths.length[0] == 6.0


def test_zero_cost_edges_are_searched_with_a_heap():
    from swazure_ros.core.paths import _buckets

    edges = [
        (0, 1, 6.0, 0.0),
        (1, 3, 6.0, 0.0),
        (0, 2, 7.0, 0.0),
        (2, 4, 7.0, 0.0),
        (4, 3, 7.0, 0.0),
    ]
    first, second, weight, cost = zip(*edges)
    free = make_graph(5, first, second, weight, costs=cost)
    assert _buckets(free.costs, False) == (0.0, 0)
    # Every path costs nothing: the fewest hops decide.
    assert shortest_paths(free, [0], [3], "least-error").path(0) == [0, 1, 3]


def test_pairs_must_be_nodes_of_the_graph():
    with pytest.raises(ValueError, match="must be nodes of the graph"):
        shortest_paths(graph([(0, 1, 1.0)]), [0], [-1], "fewest-hops")
    with pytest.raises(ValueError, match="must be nodes of the graph"):
        shortest_paths(graph([(0, 1, 1.0)]), [0], [2], "fewest-hops")


def placed_edges(rng, size, radius):
    """FLSs at whole-number places and the pairs 6 to 8 apart, each edge its distance less
    2 ``radius``: a sweet graph whose many equal lengths leave ties to the predecessor rule."""
    places = np.unique(rng.integers(0, 24, size=(size, 3)), axis=0).astype(float)
    gaps = np.linalg.norm(places[:, None] - places[None], axis=2)
    first, second = np.nonzero(np.triu((gaps >= 6.0) & (gaps <= 8.0)))
    tracking = gaps[first, second] - 2.0 * radius
    return places, first, second, tracking


@pytest.mark.parametrize("policy", ["fewest-hops", "shortest-length", "least-error"])
def test_places_give_the_paths_of_a_graph_without_them(policy):
    # With places a search leaves out the nodes too far from its targets; the labels of
    # the targets' paths, their ties and the paths are the same. The pairs are blind
    # (closer than an edge): a source's many targets, then each alone, then each avoiding
    # its path's first hop (as fusion asks).
    rng = np.random.default_rng(13)
    places, first, second, tracking = placed_edges(rng, 700, 0.25)
    costs = (tracking + 0.5) ** 2  # whole numbers: ties of cost too
    plain = make_graph(len(places), first, second, tracking, costs=costs)
    placed = make_graph(len(places), first, second, tracking, costs=costs, positions=places)
    gaps = np.linalg.norm(places[:, None] - places[None], axis=2)
    sources, targets = np.nonzero((gaps > 0) & (gaps < 6.0))
    expected = shortest_paths(plain, sources, targets, policy)
    assert expected.found.sum() > 0.9 * len(sources) and expected.hops.max() >= 3
    assert_same_paths(shortest_paths(placed, sources, targets, policy), expected)

    _, alone = np.unique(sources, return_index=True)  # one target a source
    assert_same_paths(
        shortest_paths(placed, sources[alone], targets[alone], policy),
        shortest_paths(plain, sources[alone], targets[alone], policy),
    )

    found = expected.found
    avoid_offsets = np.concatenate([[0], np.cumsum(found)])
    avoid = expected.nodes[expected.offsets[:-1][found] + 1]
    around = avoiding_paths(plain, sources, targets, policy, avoid_offsets, avoid)
    assert around.found.sum() > 0.8 * len(sources)
    assert_same_paths(
        avoiding_paths(placed, sources, targets, policy, avoid_offsets, avoid), around
    )


@pytest.mark.skipif(jit.INTERPRET, reason="the kernels run as Python: no compiled forms")
def test_pairs_given_strided_reach_the_kernels_as_contiguous_arrays():
    # np.nonzero of a matrix gives strided lists: to numba a type of their own, for which
    # each kernel would be compiled anew (20-60 s in the suite, a user's first call too).
    square = make_graph(4, [0, 1, 2, 0], [1, 2, 3, 3], [1.0, 1.0, 1.0, 5.0])
    sources, targets = np.nonzero(
        np.array([[0, 0, 1, 0], [0, 0, 0, 1], [1, 0, 0, 0], [0, 0, 0, 0]])
    )
    assert not sources.flags.c_contiguous  # the case at hand
    assert shortest_paths(square, sources, targets, "shortest-length").path(0) == [0, 1, 2]
    _, avoid = np.nonzero(np.array([[0, 1], [0, 1], [0, 1]]))  # node 1, strided
    around = avoiding_paths(square, sources, targets, "shortest-length", [0, 1, 2, 3], avoid)
    assert around.path(0) == [0, 3, 2]
    assert square.edge_positions(sources, targets).tolist() == [-1, -1, -1]
    numba = pytest.importorskip("numba")
    kernels = (
        paths_module._search_kernel,
        avoiding_module._shared_kernel,
        avoiding_module._alone_kernel,
    )
    for kernel in (*kernels, graph_module._edge_positions):
        layouts = {
            argument.layout
            for signature in kernel.compiled().signatures
            for argument in signature
            if isinstance(argument, numba.types.Array)
        }
        assert layouts == {"C"}, kernel.__name__
