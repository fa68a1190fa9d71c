import numpy as np
import pytest

from swazure_ros.core.graph import make_graph
from swazure_ros.core.path_arrays import merge_paths, path_hops, path_sums, paths_from_rows


def test_paths_from_rows_keep_each_pair_s_nodes_and_length():
    paths = paths_from_rows(3, {2: [5, 6, 7, 8], 0: [1, 2]}, {2: 4.5})
    assert paths.found.tolist() == [True, False, True]
    assert paths.hops.tolist() == [1, 0, 3]
    assert paths.offsets.tolist() == [0, 2, 2, 6]
    assert [paths.path(pair) for pair in range(3)] == [[1, 2], [], [5, 6, 7, 8]]
    np.testing.assert_array_equal(paths.length, [np.nan, np.nan, 4.5])


def test_path_hops_lists_each_path_s_hops_in_order():
    pair, start, end = path_hops(paths_from_rows(3, {0: [3, 1, 2], 2: [0, 4]}))
    assert pair.tolist() == [0, 0, 2]
    assert start.tolist() == [3, 1, 0]
    assert end.tolist() == [1, 2, 4]


def test_path_sums_add_each_edge_s_value_along_the_path():
    graph = make_graph(4, [0, 1, 2], [1, 2, 3], [1.0, 2.0, 4.0], costs=[0.5, 0.25, 0.125])
    paths = paths_from_rows(3, {0: [0, 1, 2, 3], 2: [3, 2]})
    np.testing.assert_array_equal(path_sums(graph, paths, graph.weights), [7.0, np.nan, 4.0])
    np.testing.assert_array_equal(path_sums(graph, paths, graph.costs), [0.875, np.nan, 0.125])


def test_merged_paths_take_each_pair_from_the_record_it_names():
    first = paths_from_rows(3, {0: [0, 1], 1: [2, 3, 4]}, {0: 1.0, 1: 2.0})
    second = paths_from_rows(2, {1: [5, 6, 7]}, {1: 3.0})
    merged = merge_paths(first, second, np.array([False, True, True]))
    assert [merged.path(pair) for pair in range(3)] == [[0, 1], [], [5, 6, 7]]
    assert merged.found.tolist() == [True, False, True]
    assert merged.hops.tolist() == [1, 0, 2]
    np.testing.assert_array_equal(merged.length, [1.0, np.nan, 3.0])


def test_merging_needs_one_path_of_the_second_record_per_pair_it_replaces():
    first = paths_from_rows(2, {0: [0, 1]})
    with pytest.raises(ValueError, match="exactly the pairs"):
        merge_paths(first, paths_from_rows(2, {}), np.array([False, True]))
    with pytest.raises(ValueError, match="one value per pair"):
        merge_paths(first, paths_from_rows(1, {}), np.array([True]))


def test_paths_taken_or_spanned_are_the_pairs_asked_for():
    paths = paths_from_rows(4, {0: [0, 1], 2: [2, 3, 4], 3: [5, 6]})
    taken = paths.take(np.array([3, 1, 2]))
    assert [taken.path(m) for m in range(3)] == [[5, 6], [], [2, 3, 4]]
    assert taken.found.tolist() == [True, False, True] and taken.hops.tolist() == [1, 0, 2]
    spanned = paths.span(1, 3)
    assert [spanned.path(m) for m in range(2)] == [[], [2, 3, 4]]
    assert spanned.found.tolist() == [False, True]
