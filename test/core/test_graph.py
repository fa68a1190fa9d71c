import numpy as np
import pytest

from swazure_ros.core.graph import make_graph, symmetric_rows


def random_pairs(rng, size, draws):
    """Distinct pairs (first < second) of ``size`` nodes, from ``draws`` random draws."""
    first, second = rng.integers(0, size, size=(2, draws))
    keep = first < second
    return np.unique(np.column_stack([first[keep], second[keep]]), axis=0)


def test_a_graph_is_the_same_from_sorted_pairs_and_from_edges_in_any_order():
    rng = np.random.default_rng(3)
    pairs = random_pairs(rng, 60, 400)
    weight = rng.uniform(1, 2, size=len(pairs))
    cost = rng.uniform(0, 1, size=len(pairs))
    ordered = make_graph(60, pairs[:, 0], pairs[:, 1], weight, costs=cost)
    shuffle = rng.permutation(len(pairs))
    flipped = rng.random(len(pairs)) < 0.5
    one = np.where(flipped, pairs[:, 1], pairs[:, 0])[shuffle]
    other = np.where(flipped, pairs[:, 0], pairs[:, 1])[shuffle]
    anyhow = make_graph(60, one, other, weight[shuffle], shuffle, cost[shuffle])
    for field in ("indptr", "indices", "weights", "labels", "costs"):
        np.testing.assert_array_equal(getattr(ordered, field), getattr(anyhow, field))


@pytest.mark.parametrize("shuffled", [False, True], ids=["as-neighbour-pairs-come", "any-order"])
def test_rows_without_their_entries_pairs_are_the_same_rows(shuffled):
    rng = np.random.default_rng(5)
    pairs = random_pairs(rng, 50, 300)
    if shuffled:
        pairs = pairs[rng.permutation(len(pairs))][:, ::-1]
    keep = rng.random(len(pairs)) < 0.7
    indptr, indices, edge = symmetric_rows(50, pairs[:, 0], pairs[:, 1], keep=keep)
    bare = symmetric_rows(50, pairs[:, 0], pairs[:, 1], keep=keep, edges=False)
    np.testing.assert_array_equal(bare[0], indptr)
    np.testing.assert_array_equal(bare[1], indices)
    assert len(edge) == len(indices) > 0 and len(bare[2]) == 0


def test_a_graph_keeps_its_labels_in_32_bits_where_they_fit_and_gives_them_in_64():
    narrow = make_graph(3, [0, 1], [1, 2], [1.0, 2.0], labels=[2**31 - 1, 5])
    wide = make_graph(3, [0, 1], [1, 2], [1.0, 2.0], labels=[2**31, 5])
    assert narrow.labels.dtype == np.int32 and wide.labels.dtype == np.int64
    assert narrow.edge_labels([1, 0], [0, 2]).tolist() == [2**31 - 1, -1]
    assert wide.edge_labels([2], [1]).tolist() == [5]
    assert narrow.edge_labels([1], [0]).dtype == wide.edge_labels([1], [0]).dtype == np.int64


def test_a_graph_holds_both_directions_of_each_edge_with_its_length_and_label():
    graph = make_graph(3, [1, 0], [2, 1], [2.0, 1.5], labels=[7, 9])
    assert graph.size == 3 and graph.edges == 2
    assert graph.edge_positions([0, 1, 2, 0], [1, 0, 1, 2]).tolist() == [0, 1, 3, -1]
    assert graph.edge_labels([2, 0], [1, 2]).tolist() == [7, -1]
    assert graph.weights[graph.edge_positions([1], [2])].tolist() == [2.0]
    assert graph.components().tolist() == [0, 0, 0]


@pytest.mark.parametrize(
    ("first", "second", "weights", "match"),
    [
        ([0, 1], [1], [1.0, 1.0], "must have one length"),
        ([0], [3], [1.0], "must be nodes of the graph, 0 to 2"),
        ([-1], [1], [1.0], "must be nodes of the graph, 0 to 2"),
        ([1], [1], [1.0], "cannot join a node to itself"),
    ],
)
def test_bad_edges_are_refused(first, second, weights, match):
    with pytest.raises(ValueError, match=match):
        make_graph(3, first, second, weights)


def test_costs_need_one_value_per_edge():
    with pytest.raises(ValueError, match="one value per edge"):
        make_graph(3, [0, 1], [1, 2], [1.0, 1.0], costs=[0.5])


@pytest.mark.parametrize("size", [1, 2, 60, 2000])
@pytest.mark.parametrize("density", [0.0, 0.4, 1.0, 3.0])
def test_components_are_numbered_as_scipy_numbers_them(size, density):
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    rng = np.random.default_rng(size)
    first, second = rng.integers(0, size, (2, int(size * density)))
    keep = first != second
    graph = make_graph(size, first[keep], second[keep], np.ones(keep.sum()))
    matrix = csr_matrix((np.ones(len(graph.indices)), graph.indices, graph.indptr), (size, size))
    _, expected = connected_components(matrix, directed=False)
    assert graph.components().tolist() == expected.tolist()


def test_costs_from_weights_are_computed_once_when_first_asked_and_equal_given_costs():
    calls = []

    def squared(weights):
        calls.append(len(weights))
        return weights**2

    weights = np.array([1.5, 2.0, 3.0])
    lazy = make_graph(4, [0, 1, 2], [1, 2, 3], weights, cost_of=squared)
    given = make_graph(4, [0, 1, 2], [1, 2, 3], weights, costs=weights**2)
    assert calls == [] and lazy.costs is None
    np.testing.assert_array_equal(lazy.edge_costs(), given.edge_costs())
    np.testing.assert_array_equal(lazy.edge_costs(), given.costs)
    assert calls == [6]  # both entries of each edge, once
    assert make_graph(4, [0], [1], [1.0]).edge_costs() is None


def test_costs_are_given_or_computed_not_both():
    with pytest.raises(ValueError, match="`costs` or `cost_of`, not both"):
        make_graph(3, [0], [1], [1.0], costs=[0.5], cost_of=np.sqrt)


@pytest.mark.parametrize("shuffled", [False, True], ids=["sorted-pairs", "pairs-in-any-order"])
def test_a_graph_of_the_kept_pairs_is_the_graph_of_those_pairs_labelled_by_position(shuffled):
    rng = np.random.default_rng(8)
    first, second = rng.integers(0, 40, size=(2, 300))
    pairs = np.unique(np.column_stack([first, second])[first < second], axis=0)
    if shuffled:
        pairs = pairs[rng.permutation(len(pairs))]
    weight = rng.uniform(1, 2, size=len(pairs))
    keep = rng.random(len(pairs)) < 0.4
    kept = make_graph(40, pairs[:, 0], pairs[:, 1], weight, keep=keep)
    index = np.flatnonzero(keep)
    chosen = make_graph(40, pairs[index, 0], pairs[index, 1], weight[index], labels=index)
    for field in ("indptr", "indices", "weights", "labels"):
        np.testing.assert_array_equal(getattr(kept, field), getattr(chosen, field))
    assert 0 < kept.edges < len(pairs)


def test_a_banded_graph_holds_each_row_s_entries_shortest_band_first_each_band_by_neighbour():
    rng = np.random.default_rng(5)
    pairs = random_pairs(rng, 40, 500)
    weight = rng.uniform(6.0, 30.0, size=len(pairs))
    plain = make_graph(40, pairs[:, 0], pairs[:, 1], weight)
    banded = make_graph(40, pairs[:, 0], pairs[:, 1], weight, bands=4)
    assert plain.bands is None and banded.bands is not None and banded.bands.shape == (40, 5)
    np.testing.assert_array_equal(banded.indptr, plain.indptr)
    np.testing.assert_array_equal(banded.bands[:, 0], plain.indptr[:-1])
    np.testing.assert_array_equal(banded.bands[:, -1], plain.indptr[1:])
    # Bands of 6 cm each (the weights span 6 to 30 cm): each band's entries fall in it.
    shortest, width = weight.min(), (weight.max() - weight.min()) / 4
    for node in range(40):
        starts = banded.bands[node]
        for band in range(4):
            entries = slice(starts[band], starts[band + 1])
            inside = banded.weights[entries]
            assert ((inside >= shortest + band * width - 1e-9) | (band == 0)).all()
            assert ((inside <= shortest + (band + 1) * width + 1e-9) | (band == 3)).all()
            assert (np.diff(banded.indices[entries]) > 0).all()
        # The row holds the same entries as the plain graph's, each with its weight and label.
        row = slice(plain.indptr[node], plain.indptr[node + 1])
        order = np.argsort(banded.indices[row])
        np.testing.assert_array_equal(banded.indices[row][order], plain.indices[row])
        np.testing.assert_array_equal(banded.weights[row][order], plain.weights[row])
        np.testing.assert_array_equal(banded.labels[row][order], plain.labels[row])
    # Every edge is found in its band, with its label, and a non-edge in none.
    ends = rng.integers(0, 40, size=(2, 300))
    np.testing.assert_array_equal(banded.edge_labels(*ends), plain.edge_labels(*ends))
    found = banded.edge_positions(pairs[:, 1], pairs[:, 0])
    assert (found >= 0).all() and (banded.labels[found] == np.arange(len(pairs))).all()
    # A band's floor is the least weight among its entries.
    floors = banded.band_floors()
    for band in range(4):
        least = min(
            banded.weights[banded.bands[node, band] : banded.bands[node, band + 1]].min(
                initial=np.inf
            )
            for node in range(40)
        )
        assert floors[band] == least
    assert floors.tolist() == sorted(floors.tolist()) and floors[0] == weight.min()


def test_a_graph_needs_a_band_at_least():
    with pytest.raises(ValueError, match="one band at least, got 0"):
        make_graph(3, [0], [1], [1.0], bands=0)


def test_the_reach_ratio_is_the_least_weight_per_cm_of_straight_line():
    # Three FLSs on a line 3 and 4 cm apart, and a fourth where the other two stand: its
    # edge has no straight length and bounds nothing.
    places = [[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [7.0, 0.0, 0.0], [3.0, 0.0, 0.0]]
    lengths, costs = [2.7, 3.8, 1.0], [6.0, 2.0, 0.5]
    placed = make_graph(4, [0, 1, 1], [1, 2, 3], lengths, costs=costs, positions=places)
    margin = 1.0 - 1e-9
    assert placed.reach_ratio() == pytest.approx(0.9 * margin, rel=1e-15)  # 2.7 / 3
    assert placed.reach_ratio(costs=True) == pytest.approx(0.5 * margin, rel=1e-15)  # 2 / 4
    assert placed.reach_ratio(hops=True) == pytest.approx(0.25 * margin, rel=1e-15)  # 1 / 4
    assert placed.reach_ratio() < 0.9  # below every edge's own ratio
    # Without places, or where no weight above 0 bounds a path, nothing is left out.
    assert make_graph(4, [0, 1], [1, 2], [2.7, 3.8]).reach_ratio() == 0.0
    assert make_graph(2, [0], [1], [-1.0], positions=places[:2]).reach_ratio() == 0.0
    with pytest.raises(ValueError, match="without edge costs"):
        make_graph(2, [0], [1], [1.0], positions=places[:2]).reach_ratio(costs=True)


def test_places_are_one_point_a_node():
    with pytest.raises(ValueError, match=r"`positions` must be \(3, 3\), got \(2, 3\)"):
        make_graph(3, [0], [1], [1.0], positions=np.zeros((2, 3)))
