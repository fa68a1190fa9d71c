"""Paths that avoid given FLSs: one search per pair, or one shared by the pairs of a source."""

import numpy as np
import pytest

from swazure_ros.core import avoiding
from swazure_ros.core.avoiding import avoiding_paths, sharing
from swazure_ros.core.graph import make_graph
from swazure_ros.core.paths import shortest_paths

from .test_paths import placed_edges


def test_a_path_avoiding_a_node_goes_round_it():
    square = make_graph(4, [0, 1, 2, 0], [1, 2, 3, 3], [1.0, 1.0, 1.0, 5.0])
    paths = avoiding_paths(
        square, [0, 0, 0], [2, 2, 2], "shortest-length", [0, 0, 1, 3], [1, 1, 3]
    )
    assert paths.path(0) == [0, 1, 2]
    assert paths.path(1) == [0, 3, 2]
    assert paths.length[1] == 6.0
    assert not paths.found[2]  # every way round is avoided


@pytest.mark.parametrize(
    ("offsets", "avoid", "match"),
    [
        ([0], [], "must hold 2 offsets"),
        ([0, 2], [1], "rise from 0 to the length"),
        ([1, 0], [1], "rise from 0 to the length"),
        ([0, 1], [4], "nodes of the graph"),
    ],
)
def test_avoided_nodes_must_be_rows_of_nodes(offsets, avoid, match):
    square = make_graph(4, [0, 1, 2, 0], [1, 2, 3, 3], [1.0, 1.0, 1.0, 5.0])
    with pytest.raises(ValueError, match=match):
        avoiding_paths(square, [0], [2], "shortest-length", offsets, avoid)


# Source 0 reaches 3 by 0-1-3 (length 2), 0-2-5-3 (3.5) or 0-2-6-3 (4); 1 and 2 are its
# only neighbours.
DETOURS = [(0, 1, 1.0), (1, 3, 1.0), (0, 2, 1.0), (2, 5, 1.0), (5, 3, 1.5), (2, 6, 1.0),
           (6, 3, 2.0)]  # fmt: skip


def test_pairs_that_avoid_the_same_neighbours_of_their_source_share_a_search(monkeypatch):
    monkeypatch.setattr(avoiding, "SHARED_LEAST", 1)  # a search for a group of one too
    first, second, weight = zip(*DETOURS)
    detours = make_graph(7, first, second, weight)
    avoided = [[1, 5], [1], [], [1, 2], [5], [3]]
    offsets = np.cumsum([0] + [len(nodes) for nodes in avoided])
    nodes = np.array([node for row in avoided for node in row], dtype=np.int64)
    sources, targets = np.zeros(6, dtype=np.int64), np.full(6, 3, dtype=np.int64)

    groups = sharing(detours, sources, targets, offsets, nodes, least=1)
    shared = {
        tuple(groups.order[low:high]): [int(node) for node in row if node >= 0]
        for low, high, row in zip(groups.starts[:-1], groups.starts[1:], groups.shared)
    }
    # The pairs that avoid no neighbour of 0 search avoiding nothing; one that avoids
    # its own target (5) is searched alone.
    assert shared == {(2, 4): [], (0, 1): [1], (3,): [1, 2]}
    assert groups.alone.tolist() == [5]
    assert sharing(detours, sources, targets, offsets, nodes, least=2).alone.tolist() == [3, 5]

    paths = avoiding_paths(detours, sources, targets, "shortest-length", offsets, nodes)
    # Pair 0's shared path (0-2-5-3, avoiding 1) enters 5, which it avoids: searched again.
    assert [paths.path(pair) for pair in range(3)] == [[0, 2, 6, 3], [0, 2, 5, 3], [0, 1, 3]]
    assert not paths.found[3] and not paths.found[5]
    assert paths.path(4) == [0, 1, 3]


@pytest.mark.parametrize("policy", ["fewest-hops", "shortest-length", "least-error"])
@pytest.mark.parametrize("least", [1, 2])  # this small graph has few large groups
def test_each_pair_gets_the_path_of_its_graph_without_its_avoided_nodes(
    monkeypatch, policy, least
):
    # A graph full of ties (whole-number places). Each pair avoids its first path's inner
    # FLSs, then those of its second path too, as fusion asks; the expected path is the
    # policy's in the graph without the pair's avoided FLSs, whose indices are the same.
    monkeypatch.setattr(avoiding, "SHARED_LEAST", least)
    rng = np.random.default_rng(21)
    places, first, second, tracking = placed_edges(rng, 500, 0.25)
    costs = (tracking + 0.5) ** 2
    placed = make_graph(len(places), first, second, tracking, costs=costs, positions=places)
    gaps = np.linalg.norm(places[:, None] - places[None], axis=2)
    sources, targets = np.nonzero((gaps > 0) & (gaps < 6.0))
    kept = np.isin(sources, np.unique(sources)[:12])  # a dozen sources, all their targets
    sources, targets = sources[kept], targets[kept]
    paths = shortest_paths(placed, sources, targets, policy)
    avoided = [[] for _ in sources]
    for _ in range(2):
        for pair in np.flatnonzero(paths.found):
            avoided[pair] += paths.path(pair)[1:-1]
        offsets = np.cumsum([0] + [len(nodes) for nodes in avoided])
        nodes = np.array([node for row in avoided for node in row], dtype=np.int64)
        groups = sharing(placed, sources, targets, offsets, nodes, least)
        assert 0 < len(groups.starts) - 1 < len(sources)  # searches shared
        paths = avoiding_paths(placed, sources, targets, policy, offsets, nodes)
        assert paths.found.sum() > 0.5 * len(sources)
        for pair, (source, target) in enumerate(zip(sources, targets, strict=True)):
            clear = ~np.isin(first, avoided[pair]) & ~np.isin(second, avoided[pair])
            without = make_graph(
                len(places), first[clear], second[clear], tracking[clear],
                costs=costs[clear], positions=places,
            )  # fmt: skip
            alone = shortest_paths(without, [source], [target], policy)
            assert paths.found[pair] == alone.found[0]
            if alone.found[0]:
                assert paths.path(pair) == alone.path(0)
                assert paths.length[pair] == alone.length[0]
