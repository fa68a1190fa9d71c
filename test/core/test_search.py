import numpy as np

from swazure_ros.core.graph import make_graph
from swazure_ros.core.paths import _search_of
from swazure_ros.core.search import fresh_labels, search_from, walk_back


def lattice(side):
    """FLSs on a square lattice 1 cm apart, each joined to the eight around it: (places,
    first, second, length)."""
    grid = np.stack(np.meshgrid(np.arange(side), np.arange(side), indexing="ij"), axis=-1)
    places = np.column_stack([grid.reshape(-1, 2), np.zeros(side * side)]).astype(float)
    gaps = np.linalg.norm(places[:, None] - places[None], axis=2)
    first, second = np.nonzero(np.triu((gaps > 0) & (gaps < 1.5)))
    return places, first, second, gaps[first, second]


def searched(graph, source, targets):
    """The nodes a search touched, and the path to each target."""
    labels = fresh_labels(graph.size)
    touched = search_from(_search_of(graph, "shortest-length", None), source, targets, labels)
    paths = []
    for target in targets:
        path = np.empty(int(labels.secondary[target]) + 1, dtype=np.int64)
        walk_back(labels.pred, target, len(path) - 1, path)
        paths.append(path.tolist())
    return touched, paths


def test_places_keep_a_search_near_its_targets_and_find_the_same_paths():
    # From the middle of a 41 x 41 lattice toward a node 3 cm away: without places the
    # search labels a ball around the source; with them it leaves out the nodes whose
    # distance to the target shows they cannot be on its path.
    places, first, second, length = lattice(41)
    plain = make_graph(len(places), first, second, length)
    placed = make_graph(len(places), first, second, length, positions=places)
    source, target = 20 * 41 + 20, 23 * 41 + 20
    everywhere, expected = searched(plain, source, np.array([target]))
    nearby, found = searched(placed, source, np.array([target]))
    assert found == expected and expected[0][0] == source and len(expected[0]) == 4
    assert nearby < 0.6 * everywhere

    # Several targets: the nodes left out are those beyond the ball that holds them all.
    targets = np.array([target, 20 * 41 + 23, 17 * 41 + 20])
    everywhere, expected = searched(plain, source, targets)
    nearby, found = searched(placed, source, targets)
    assert found == expected
    assert nearby < everywhere
