import numpy as np
import pytest

from swazure_ros.core.geometry import centre_distance, make_swarm
from swazure_ros.core.neighbours import FIELDS, NeighbourPairs, neighbour_pairs
from swazure_ros.core.pair_scan import Affordable
from swazure_ros.core.sensor import DECAYING, SWEET


def random_swarm(seed, count=400, extent=60.0):
    rng = np.random.default_rng(seed)
    return make_swarm(rng.uniform(0, extent, size=(count, 3)), radius=0.5)


@pytest.mark.parametrize("seed", [1, 2])
def test_neighbour_pairs_are_every_pair_within_reach_sorted(sensor, seed):
    swarm = random_swarm(seed)
    pairs = neighbour_pairs(swarm, sensor)
    first, second = np.triu_indices(swarm.size, k=1)
    distance = centre_distance(swarm.points, first, second)
    tracking = distance - 2 * swarm.radius
    within = tracking < sensor.decaying_max
    np.testing.assert_array_equal(pairs.first, first[within])
    np.testing.assert_array_equal(pairs.second, second[within])
    np.testing.assert_array_equal(pairs.distance, distance[within])
    np.testing.assert_array_equal(pairs.tracking, tracking[within])
    np.testing.assert_array_equal(pairs.range_class, sensor.classify(tracking[within]))
    # A block of first FLSs, within a shorter reach: the whole list's pairs of both.
    block = neighbour_pairs(swarm, sensor, 100, 250, longest=sensor.sweet_max)
    chosen = within & (first >= 100) & (first < 250) & (tracking < sensor.sweet_max)
    for field, expected in (("first", first), ("second", second), ("distance", distance)):
        np.testing.assert_array_equal(getattr(block, field), expected[chosen])


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


def test_the_pairs_involving_some_flss_are_the_whole_list_s_selection_of_them(sensor):
    swarm = random_swarm(4)
    whole = neighbour_pairs(swarm, sensor)
    involving = np.zeros(swarm.size, dtype=bool)
    involving[::3] = True  # every third FLS: pairs with one, both or neither of them
    part = neighbour_pairs(swarm, sensor, involving=involving)
    chosen = involving[whole.first] | involving[whole.second]
    assert 0 < chosen.sum() < len(whole)
    for field in ("first", "second", "distance", "tracking", "range_class"):
        np.testing.assert_array_equal(getattr(part, field), getattr(whole, field)[chosen])
    # And within a block of first FLSs, as the engine asks for one.
    block = neighbour_pairs(swarm, sensor, 100, 250, involving=involving)
    inside = chosen & (whole.first >= 100) & (whole.first < 250)
    np.testing.assert_array_equal(block.second, whole.second[inside])


def test_the_affordable_pairs_are_those_whose_ends_spare_their_cost(sensor):
    swarm = random_swarm(6)
    whole = neighbour_pairs(swarm, sensor)
    spare = np.random.default_rng(6).uniform(0.0, 20.0, swarm.size)
    spare[::7] = -np.inf  # FLSs that spare nothing: none of their pairs
    for per_cm, fixed in ((1.2, -1.0), (0.0, 15.0)):
        part = neighbour_pairs(swarm, sensor, affordable=Affordable(spare, per_cm, fixed))
        chosen = spare[whole.first] + spare[whole.second] >= per_cm * whole.distance + fixed
        assert 0 < chosen.sum() < len(whole)
        for field in FIELDS:
            np.testing.assert_array_equal(getattr(part, field), getattr(whole, field)[chosen])


def test_the_pairs_no_nearer_than_the_shortest_are_the_whole_list_s_selection_of_them(sensor):
    # A region's search hops over no blind pair: found without them, the rest as the whole's.
    swarm = random_swarm(7, count=600, extent=40.0)
    whole = neighbour_pairs(swarm, sensor)
    part = neighbour_pairs(swarm, sensor, shortest=sensor.sweet_min)
    chosen = whole.tracking >= sensor.sweet_min
    assert (~chosen).any() and chosen.any()
    for field in FIELDS:
        np.testing.assert_array_equal(getattr(part, field), getattr(whole, field)[chosen])
    # A pair exactly at the shortest (tracking 7 - 2 * 0.5 = 6 cm) is kept; a hair beyond, not.
    line = make_swarm([[0.0, 0, 0], [7.0, 0, 0], [3.0, 0, 0]], radius=0.5)
    kept = neighbour_pairs(line, sensor, shortest=6.0)
    assert (kept.first.tolist(), kept.second.tolist(), kept.tracking.tolist()) == ([0], [1], [6.0])
    assert len(neighbour_pairs(line, sensor, shortest=float(np.nextafter(6.0, 7.0)))) == 0


def test_a_mask_of_another_length_is_refused(sensor):
    swarm = random_swarm(5, count=20)
    with pytest.raises(ValueError, match=r"`involving` must be \(20,\) bools"):
        neighbour_pairs(swarm, sensor, involving=np.ones(19, dtype=bool))
    with pytest.raises(ValueError, match=r"`affordable.spare` must be \(20,\) values"):
        neighbour_pairs(swarm, sensor, affordable=Affordable(np.zeros(19), 1.0, 0.0))


def test_pairs_merged_with_pairs_given_in_pieces_are_the_sorted_union(sensor):
    # The sweet pairs, and the decaying pairs in pieces (a display's blocks): one sorted list.
    pairs = neighbour_pairs(random_swarm(4), sensor)
    sweet = pairs.select(pairs.range_class == SWEET)
    decaying = np.flatnonzero(pairs.range_class == DECAYING)
    pieces = np.array_split(decaying, 3)
    columns = {name: [getattr(pairs, name)[piece] for piece in pieces] for name in FIELDS}
    merged, from_columns = sweet.merged(columns, 400)
    both = np.sort(np.concatenate([np.flatnonzero(pairs.range_class == SWEET), decaying]))
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(merged, name), getattr(pairs, name)[both])
    assert from_columns.tolist() == (pairs.range_class[both] == DECAYING).tolist()
    assert columns == {}  # each field's pieces let go once placed
    assert 0 < len(sweet) < len(merged)


def test_pairs_from_pieces_are_the_pieces_joined_in_order_and_let_go(sensor):
    pairs = neighbour_pairs(random_swarm(6), sensor)
    pieces = np.array_split(np.arange(len(pairs)), 4)
    columns = {name: [getattr(pairs, name)[piece] for piece in pieces] for name in FIELDS}
    joined = NeighbourPairs.from_pieces(columns)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(joined, name), getattr(pairs, name))
    assert columns == {} and len(pairs) > 4


def test_pairs_merged_with_no_pieces_are_themselves(sensor):
    pairs = neighbour_pairs(random_swarm(5), sensor)
    merged, from_columns = pairs.merged({name: [] for name in FIELDS}, 400)
    assert merged.first.tolist() == pairs.first.tolist() and not from_columns.any()
