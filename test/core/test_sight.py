import numpy as np

from swazure_ros.core import sight
from swazure_ros.core.grid import build_grid
from swazure_ros.core.sight import CLOSE, SERIAL_SEGMENTS, _close_points, obstructed, obstructers


def segment_with(offset: float) -> np.ndarray:
    """A segment from (0,0,0) to (10,0,0) and a third FLS at (5, offset, 0)."""
    return np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [5.0, offset, 0.0]])


def test_centre_exactly_r_from_the_segment_obstructs():
    assert obstructed(segment_with(0.5), 0.5, [0], [1]).tolist() == [True]


def test_centre_just_beyond_r_does_not_obstruct():
    assert obstructed(segment_with(0.5001), 0.5, [0], [1]).tolist() == [False]


def test_line_of_sight_is_symmetric():
    points = segment_with(0.3)
    assert obstructed(points, 0.5, [0, 1], [1, 0]).tolist() == [True, True]


def test_the_ends_never_obstruct_their_own_segment():
    points = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [30.0, 0.0, 0.0]])
    assert obstructed(points, 0.5, [0], [1]).tolist() == [False]


def test_points_beyond_the_segment_ends_do_not_obstruct():
    # On the line but beyond the far end: more than r from the segment.
    points = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [11.2, 0.0, 0.0]])
    assert obstructed(points, 0.5, [0], [1]).tolist() == [False]


def test_obstructers_lists_every_obstructing_fls_sorted():
    points = np.array([[0, 0, 0], [10, 0, 0], [7, 0.2, 0], [3, -0.1, 0.1], [5, 2, 0]], dtype=float)
    offsets, ids = obstructers(points, 0.5, [0, 0], [1, 4])
    assert ids[offsets[0] : offsets[1]].tolist() == [2, 3]


def brute_force(points, radius, first, second):
    """Whether each segment is obstructed, from every FLS's distance to it."""
    judged = []
    for a, b in zip(first, second):
        direction = points[b] - points[a]
        length = np.linalg.norm(direction)
        offset = points - points[a]
        along = np.clip(offset @ direction / length, 0, length)
        distance = np.linalg.norm(offset - along[:, None] * direction / length, axis=1)
        distance[[a, b]] = np.inf
        judged.append(bool((distance <= radius).any()))
    return judged


def random_segments(seed):
    """300 FLSs in a 20 cm cube, r = 0.4 cm, and 2,000 segments between them."""
    rng = np.random.default_rng(seed)
    points = rng.uniform(0, 20, size=(300, 3))
    first, second = rng.integers(0, 300, size=(2, 2000))
    keep = first != second
    return points, 0.4, first[keep], second[keep]


def test_grid_search_matches_brute_force_on_random_swarms():
    points, radius, first, second = random_segments(11)
    result = obstructed(points, radius, first, second)
    assert result.tolist() == brute_force(points, radius, first, second)


def test_a_few_segments_judged_on_the_calling_thread_match_brute_force():
    # Fewer than SERIAL_SEGMENTS a call: no lists of the FLSs close to the ends.
    points, radius, first, second = random_segments(13)
    few = SERIAL_SEGMENTS // 10
    result = [
        judged
        for start in range(0, len(first), few)
        for judged in obstructed(
            points, radius, first[start : start + few], second[start : start + few]
        ).tolist()
    ]
    expected = brute_force(points, radius, first, second)
    assert result == expected
    assert 0.05 < np.mean(expected) < 0.95


def test_every_pair_of_a_dense_cloud_is_judged_as_its_obstructers_say():
    # All pairs sorted by their first FLS: segments from one FLS share obstructers,
    # which the yes-or-no judgement tries first.
    rng = np.random.default_rng(12)
    points = rng.uniform(0, 6, size=(250, 3))
    first, second = np.triu_indices(len(points), k=1)
    judged = obstructed(points, 0.3, first, second)
    offsets, _ = obstructers(points, 0.3, first, second)
    np.testing.assert_array_equal(judged, np.diff(offsets) > 0)
    assert 0.2 < judged.mean() < 0.95


def test_the_flss_close_to_the_segments_ends_are_listed_for_those_ends_alone(monkeypatch):
    # Each judgement lists the FLSs close to its segments' ends, not to every FLS of the
    # swarm: a display's regions judge a few thousand FLSs' segments at a time.
    rng = np.random.default_rng(14)
    points = rng.uniform(0, 8, size=(300, 3))
    radius = 0.3
    ends = np.array([3, 40, 41, 299])
    offsets, ids = _close_points(points, build_grid(points, radius), CLOSE * radius, ends)
    distance = np.linalg.norm(points[:, None] - points[None], axis=2)
    for node in range(len(points)):
        listed = sorted(ids[offsets[node] : offsets[node + 1]].tolist())
        close = np.flatnonzero((distance[node] <= CLOSE * radius) & (np.arange(300) != node))
        assert listed == (close.tolist() if node in ends else []), node
    assert offsets[-1] > 0
    # And a judgement asks for its segments' ends alone: here a third of the FLSs.
    asked = []
    monkeypatch.setattr(
        sight, "_close_points", lambda *args: asked.append(args[3]) or _close_points(*args)
    )
    first, second = rng.integers(0, 100, size=(2, 2 * SERIAL_SEGMENTS))
    first, second = first[first != second], second[first != second]
    assert obstructed(points, radius, first, second).tolist() == brute_force(
        points, radius, first, second
    )
    assert [one.tolist() for one in asked] == [np.unique([first, second]).tolist()]
