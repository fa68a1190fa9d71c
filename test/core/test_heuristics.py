"""Move Obstructing and Move Source on hand-built swarms with known answers, and invariants."""

import itertools
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.circles import circle_sphere_crossings, fixed_axis, free_circle_point
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, REASON_BLOCKED, SWEET_PATH
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.compat import PUBLISHED, Compat
from swazure_ros.core.heuristics.folding import apply, heuristic_facts, run_technique
from swazure_ros.core.heuristics.obstructing import move_obstructing
from swazure_ros.core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE
from swazure_ros.core.heuristics.source import DIRECTIONS, move_source
from swazure_ros.core.hop_errors import measured_vectors
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.sensors import load_sensor

from ..conftest import dataset

R = 0.5
A, B, C = np.array([0.0, 0, 0]), np.array([2.0, 7, 0]), np.array([4.0, 0, 0])
MIDPOINT = (A + B) / 2
ACROSS = np.array([7.0, -2.0, 0.0]) / np.sqrt(53)  # in the plane, perpendicular to A-B


def blocked_scene(*extra):
    """A, B, C with A-B (sweet) obstructed by the extra FLSs; (A, C) is blind. r = 0.5."""
    return make_swarm(np.vstack([A, B, C, *extra]), radius=R)


def pair_index(evaluation, source, target):
    pairs = evaluation.pairs
    return int(np.flatnonzero((pairs.source == source) & (pairs.target == target))[0])


def test_one_obstructer_moves_exactly_r_minus_u(sensor):
    u = 0.2
    evaluation = evaluate(blocked_scene(MIDPOINT + u * ACROSS), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    assert evaluation.pairs.reason[m] == REASON_BLOCKED
    result = move_obstructing(evaluation)
    assert result.tried[m] and result.resolved[m]
    [(fls, start, end)] = result.moves(m)
    assert fls == 3
    # Just outside the circle of radius r: by a relative 1e-9 (heuristics' docstring).
    aside = R * (1 + 1e-9)
    assert np.linalg.norm(end - start) == pytest.approx(aside - u, abs=1e-12)
    np.testing.assert_allclose(end, MIDPOINT + aside * ACROSS, atol=1e-12)
    assert result.paths.path(m) == [0, 1, 2]
    hops = measured_vectors(sensor, evaluation.hood.swarm.points, R, [0, 1], [1, 2])
    np.testing.assert_allclose(result.estimate[m], hops.sum(axis=0), atol=1e-12)
    after = apply(evaluation, result)
    assert after.pairs.status[m] == SWEET_PATH
    assert after.summary.heuristic.resolved_pairs == 2  # (A, C) and (C, A)
    assert after.summary.heuristic.moved_distance.max == pytest.approx(aside - u, abs=1e-12)


def test_nearest_free_point_blocked_by_a_neighbour_gives_the_sphere_boundary(sensor):
    obstructer = MIDPOINT + 0.2 * ACROSS
    neighbour = MIDPOINT + 1.4 * ACROSS  # its sphere of radius 2r covers the ideal point
    evaluation = evaluate(blocked_scene(obstructer, neighbour), sensor, "shortest-length")
    result = move_obstructing(evaluation)
    m = pair_index(evaluation, 0, 2)
    assert result.resolved[m]
    [(fls, start, end)] = result.moves(m)
    assert fls == 3
    assert np.linalg.norm(end - neighbour) == pytest.approx(2 * R, abs=1e-9)
    # On the obstruction-free circle: r (just over) from the line of sight, in the plane
    # through c.
    direction = (B - A) / np.linalg.norm(B - A)
    assert (end - MIDPOINT) @ direction == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(end - MIDPOINT) == pytest.approx(R * (1 + 1e-9), abs=1e-12)
    assert np.linalg.norm(end - start) > R - 0.2  # more than the ideal move


def test_whole_circle_blocked_fails_and_falls_back(sensor):
    normal = np.cross((B - A) / np.linalg.norm(B - A), ACROSS)
    ring = [
        MIDPOINT + 1.1 * (np.cos(angle) * ACROSS + np.sin(angle) * normal)
        for angle in np.radians([60, 180, 300])
    ]
    evaluation = evaluate(blocked_scene(MIDPOINT + 0.2 * ACROSS, *ring), sensor, "fewest-hops")
    m = pair_index(evaluation, 0, 2)
    result = move_obstructing(evaluation)
    assert result.tried[m] and not result.resolved[m]
    after = apply(evaluation, result)
    assert after.pairs.status[m] == NO_PATH  # nothing decaying in sight to fall back on


def test_two_obstructers_on_one_hop_both_move(sensor):
    first = A + (B - A) / 3 + 0.2 * ACROSS
    second = A + 2 * (B - A) / 3 - 0.1 * ACROSS
    evaluation = evaluate(blocked_scene(first, second), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    result = move_obstructing(evaluation)
    assert result.resolved[m]
    moves = result.moves(m)
    assert [fls for fls, _, _ in moves] == [3, 4]
    distances = [np.linalg.norm(end - start) for _, start, end in moves]
    np.testing.assert_allclose(distances, [R - 0.2, R - 0.1], atol=1e-12)


def test_free_circle_point_without_blockers_is_the_ideal_move():
    point = free_circle_point(
        np.zeros(3), np.array([0, 0, 1.0]), np.array([0.1, 0, 0]), 0.5, np.empty((0, 3)), 1.0
    )
    np.testing.assert_allclose(point, [0.5, 0, 0])


# Move Source scene: A-B along x (sweet) blocked by K on the line; C blind to A,
# sweet and in sight of B. Probing from A, every direction stays blocked by K up
# to delta = 2; at delta = 3 the first direction, (-1, -1, -1), clears it.
SOURCE_SCENE = np.array([[0, 0, 0], [7.5, 0, 0], [2, 5, 0], [3.75, 0, 0]], dtype=float)


def probe_path(threshold_delta, last_direction):
    """Positions the source flies through: every probe up to the successful one."""
    positions = [SOURCE_SCENE[0]]
    for delta in range(1, threshold_delta + 1):
        for d, direction in enumerate(DIRECTIONS):
            positions.append(SOURCE_SCENE[0] + delta * R * direction)
            if delta == threshold_delta and d == last_direction:
                return np.array(positions)
    return np.array(positions)


def test_move_source_first_success_direction_delta_and_distances(sensor):
    evaluation = evaluate(make_swarm(SOURCE_SCENE, radius=R), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    assert evaluation.pairs.reason[m] == REASON_BLOCKED
    result = move_source(evaluation, threshold=10)
    assert result.resolved[m]
    [(fls, start, end)] = result.moves(m)
    assert fls == 0
    np.testing.assert_allclose(end, 3 * R * DIRECTIONS[0], atol=1e-12)
    assert result.paths.path(m) == [0, 1, 2]
    flown = np.linalg.norm(np.diff(probe_path(3, 0), axis=0), axis=1).sum()
    assert result.flown[m] == pytest.approx(flown, rel=1e-12)
    assert np.linalg.norm(end - start) == pytest.approx(1.5, abs=1e-12)
    np.testing.assert_allclose(result.truth[m], SOURCE_SCENE[2] - end, atol=1e-12)
    after = apply(evaluation, result)
    assert after.pairs.status[m] == SWEET_PATH
    assert after.summary.heuristic.flown_distance.max >= flown - 1e-9


def test_move_source_threshold_limits_the_search(sensor):
    evaluation = evaluate(make_swarm(SOURCE_SCENE, radius=R), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    result = move_source(evaluation, threshold=2)
    assert result.tried[m] and not result.resolved[m]
    assert result.moves(m) == []
    assert result.flown[m] == pytest.approx(
        np.linalg.norm(np.diff(probe_path(2, 25), axis=0), axis=1).sum(), rel=1e-12
    )


def test_move_source_drops_a_direction_that_collides(sensor):
    # An FLS 1.6 cm out along the first direction: the probe at delta = 1 is 1.1 cm
    # (> 2r) from it and allowed; the probe at delta = 2 is 0.6 cm away: the direction dies.
    blocker = 1.6 * DIRECTIONS[0]
    swarm = make_swarm(np.vstack([SOURCE_SCENE, blocker]), radius=R)
    evaluation = evaluate(swarm, sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    result = move_source(evaluation, threshold=10)
    assert result.resolved[m]
    [(_, _, end)] = result.moves(m)
    # Without the drop, delta = 3 in direction 0 would succeed (as in the scene above).
    np.testing.assert_allclose(end, 3 * R * DIRECTIONS[2], atol=1e-12)
    # The flight, probe by probe as section 8 states it: a direction dies at its first
    # colliding probe; the source flies through every other probe up to the success.
    others = swarm.points[1:]
    alive = np.ones(len(DIRECTIONS), dtype=bool)
    visited = [SOURCE_SCENE[0]]
    for delta in (1, 2, 3):
        for d, direction in enumerate(DIRECTIONS):
            if not alive[d]:
                continue
            probe = SOURCE_SCENE[0] + delta * R * direction
            if (np.linalg.norm(others - probe, axis=1) < 2 * R).any():
                alive[d] = False
                continue
            visited.append(probe)
            if np.allclose(probe, end):
                break
    assert not alive[0]
    np.testing.assert_allclose(visited[-1], end)
    flown = np.linalg.norm(np.diff(np.array(visited), axis=0), axis=1).sum()
    assert result.flown[m] == pytest.approx(flown, rel=1e-12)


def segment_distance(start, end, point):
    direction = end - start
    along = np.clip((point - start) @ direction / (direction @ direction), 0, 1)
    return np.linalg.norm(point - (start + along[..., None] * direction), axis=-1)


@pytest.mark.parametrize("technique", ["move-obstructing", "move-source"])
def test_resolved_pairs_have_clear_sweet_hops_and_no_collisions(sensor, technique):
    swarm = make_swarm(load_cloud("torus:300").points, beta=0.5)
    evaluation = evaluate(swarm, sensor, "shortest-length")
    if technique == "move-obstructing":
        result = move_obstructing(evaluation)
    else:
        result = move_source(evaluation, threshold=10)
    resolved = np.flatnonzero(result.resolved)
    assert len(resolved) > 0
    radius = swarm.radius
    for m in resolved[:: max(1, len(resolved) // 150)]:
        points = swarm.points.copy()
        for fls, _, end in result.moves(m):
            points[fls] = end
        for fls, _, _ in result.moves(m):
            gaps = np.linalg.norm(points - points[fls], axis=1)
            gaps[fls] = np.inf
            assert gaps.min() >= 2 * radius - 1e-9
        path = result.paths.path(m)
        for a, b in itertools.pairwise(path):
            tracking = np.linalg.norm(points[b] - points[a]) - 2 * radius
            assert sensor.sweet_min <= tracking < sensor.sweet_max
            distance = segment_distance(points[a], points[b], points)
            distance[[a, b]] = np.inf
            # An FLS on the obstruction-free circle only touches the line of sight.
            assert distance.min() >= radius - 1e-9


@pytest.mark.parametrize("technique", [MOVE_OBSTRUCTING, MOVE_SOURCE])
def test_moved_distance_counts_resolved_pairs_and_reports_failed_ones_and_totals_apart(technique):
    swarm = make_swarm(load_cloud("torus:120", 1.6).points, beta=0.5)
    evaluation = evaluate(swarm, load_sensor(), "shortest-length")
    _, heuristic = run_technique(evaluation, technique, 10)
    facts = heuristic_facts(heuristic)
    offsets, distance = heuristic.move_offsets, heuristic.move_distance
    resolved_moves, failed_moves, totals = [], [], []
    for pair in range(len(heuristic.resolved)):
        mine = distance[offsets[pair] : offsets[pair + 1]].tolist()
        if heuristic.resolved[pair]:
            resolved_moves += mine
            totals.append(sum(mine))
        else:
            failed_moves += mine
    assert facts.moved_distance.count == len(resolved_moves) > 0
    assert facts.moved_distance.max == pytest.approx(max(resolved_moves))
    assert facts.failed_moved_distance.count == len(failed_moves)
    if technique == MOVE_OBSTRUCTING:
        assert failed_moves  # here obstructers stepped aside for pairs that still failed
    assert facts.moved_per_resolved_pair.count == facts.resolved_pairs
    assert facts.moved_per_resolved_pair.mean == pytest.approx(np.mean(totals))
    assert facts.moved_per_resolved_pair.max == pytest.approx(max(totals))


# --compat published: the published reference code's behaviours, switch by switch.
INDEPENDENT = Compat(independent_moves=True)
NORMAL = np.cross((B - A) / np.linalg.norm(B - A), ACROSS)


def test_circle_sphere_crossings_lie_on_both_and_none_when_apart():
    centre, normal = np.zeros(3), np.array([0.0, 0.0, 1.0])
    points = circle_sphere_crossings(centre, normal, 1.0, np.array([1.5, 0.0, 0.0]), 1.0)
    half = np.sqrt(1 - 0.75**2)
    np.testing.assert_allclose(
        points[np.argsort(points[:, 1])], [[0.75, -half, 0], [0.75, half, 0]]
    )
    far = circle_sphere_crossings(centre, normal, 1.0, np.array([3.5, 0.0, 0.0]), 1.0)
    assert far.shape == (0, 3)


def test_switches_of_the_independent_moves_need_it():
    with pytest.raises(ValueError, match="last_hop_decides needs independent_moves"):
        Compat(last_hop_decides=True)
    assert PUBLISHED.switches_on()[0] == "independent_moves" and Compat().switches_on() == []
    assert all(Compat.describe(name) for name in PUBLISHED.switches_on())


def obstructed_pair(extra, compat, policy="shortest-length"):
    """Move Obstructing on pair (A, C) of a blocked scene: (resolved, moves)."""
    evaluation = evaluate(blocked_scene(*extra), load_sensor(), policy)
    m = pair_index(evaluation, 0, 2)
    assert evaluation.pairs.reason[m] == REASON_BLOCKED
    result = move_obstructing(evaluation, compat)
    return result.resolved[m], result.moves(m)


def test_only_the_last_neighbours_crossings_count_with_last_neighbour_circle():
    obstructer = MIDPOINT + 0.2 * ACROSS
    near = MIDPOINT + 1.4 * ACROSS  # covers the ideal point; its sphere crosses the circle
    # Within 4r of the obstructer and farther than `near`, but its sphere misses the circle.
    far = MIDPOINT + 1.5 * ACROSS - 1.2 * (B - A) / np.linalg.norm(B - A)
    scene = [obstructer, near, far]
    text, independent = obstructed_pair(scene, Compat()), obstructed_pair(scene, INDEPENDENT)
    assert text[0] and independent[0]
    np.testing.assert_allclose(independent[1][0][2], text[1][0][2], atol=1e-9)
    assert obstructed_pair(scene, Compat(independent_moves=True, last_neighbour_circle=True)) == (
        False,
        [],
    )


def test_a_destination_clear_of_any_one_neighbour_may_collide_with_another():
    obstructer, first = MIDPOINT + 0.2 * ACROSS, MIDPOINT + 1.4 * ACROSS
    crossing = circle_sphere_crossings(MIDPOINT, B - A, R, first, 2 * R)[0]
    second = crossing + np.array([0.0, 0.0, -0.9])  # covers one of first's crossings
    scene = [obstructer, first, second]
    for compat, collides in (
        (INDEPENDENT, False),
        (replace(INDEPENDENT, clear_of_any_one=True), True),
    ):
        resolved, [(fls, _, end)] = obstructed_pair(scene, compat)
        assert resolved and fls == 3
        nearest = min(np.linalg.norm(end - first), np.linalg.norm(end - second))
        assert (nearest < 2 * R - 1e-9) == collides


def test_the_last_obstructed_hop_decides_with_last_hop_decides():
    # Hop A-B cannot be cleared (the circle is ringed); hop B-C can.
    ring = [
        MIDPOINT + 1.1 * (np.cos(angle) * ACROSS + np.sin(angle) * NORMAL)
        for angle in np.radians([60, 180, 300])
    ]
    across_bc = np.array([7.0, 2.0, 0.0]) / np.sqrt(53)
    scene = [MIDPOINT + 0.2 * ACROSS, *ring, (B + C) / 2 + 0.2 * across_bc]
    assert not obstructed_pair(scene, Compat(), "fewest-hops")[0]
    assert not obstructed_pair(scene, INDEPENDENT, "fewest-hops")[0]
    resolved, moves = obstructed_pair(
        scene, replace(INDEPENDENT, last_hop_decides=True), "fewest-hops"
    )
    assert resolved and [fls for fls, _, _ in moves] == [7]  # B-C's obstructer; A-B's cannot


def source_pair(compat, threshold):
    evaluation = evaluate(make_swarm(SOURCE_SCENE, radius=R), load_sensor(), "shortest-length")
    m = pair_index(evaluation, 0, 2)
    return move_source(evaluation, threshold, compat), m


def test_grid_steps_reach_sqrt3_r_per_step_on_a_space_diagonal():
    result, m = source_pair(Compat(grid_steps=True), threshold=2)
    # The text needs delta = 3 (test above); the unnormalised (-1, -1, -1) clears K at 2.
    assert result.resolved[m]
    [(_, start, end)] = result.moves(m)
    np.testing.assert_allclose(end, 2 * R * np.array([-1.0, -1.0, -1.0]), atol=1e-12)
    assert np.linalg.norm(end - start) == pytest.approx(2 * R * np.sqrt(3))


def test_published_flown_adds_the_previous_offset_to_each_probes():
    result, m = source_pair(Compat(published_flown=True), threshold=2)
    positions = probe_path(2, 25) - SOURCE_SCENE[0]
    expected = np.linalg.norm(positions[:-1] + positions[1:], axis=1).sum()
    assert not result.resolved[m]
    assert result.flown[m] == pytest.approx(expected, rel=1e-12)


def test_published_mode_gives_the_papers_move_obstructing_no_path_on_the_chess_piece():
    # The paper's Table 2: Move Obstructing on the chess piece at beta 0.5, 21.43 % no path.
    swarm = make_swarm(load_cloud(dataset("chess_408.xyz")).points, beta=0.5)
    evaluation = evaluate(swarm, load_sensor(), "shortest-length")
    text, _ = run_technique(evaluation, MOVE_OBSTRUCTING)
    published, heuristic = run_technique(evaluation, MOVE_OBSTRUCTING, compat=PUBLISHED)
    assert round(published.summary.pairs.no_path_pct, 2) == 21.43
    assert round(text.summary.pairs.no_path_pct, 2) == 6.02
    assert heuristic.compat == PUBLISHED
    assert list(published.summary.heuristic.compat) == PUBLISHED.switches_on()


def test_a_helper_at_exactly_the_sweet_maximum_counts_with_sweet_max_inclusive():
    # From the probe (-0.5, 0, 0) (delta 1, direction (-1, 0, 0)) H is (1, -8, 4) away:
    # 9 cm, tracking exactly 8 = sweet_max, decaying by the text's [6, 8), sweet as published.
    scene = np.array([[0, 0, 0], [0.5, -8, 4], [-6, -3, 1], [0.55, -4, 2]], dtype=float)
    sensor = load_sensor()
    evaluation = evaluate(make_swarm(scene, radius=R), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    assert evaluation.pairs.reason[m] == REASON_BLOCKED
    probe = R * DIRECTIONS[4]
    np.testing.assert_array_equal(probe, [-0.5, 0.0, 0.0])
    offset = scene[1] - probe
    assert np.sqrt(offset @ offset) - 2 * R == sensor.sweet_max == 8.0
    text = move_source(evaluation, 1)
    inclusive = move_source(evaluation, 1, Compat(sweet_max_inclusive=True))
    [(_, _, end)] = inclusive.moves(m)
    np.testing.assert_array_equal(end, probe)
    assert inclusive.paths.path(m) == [0, 1, 2]
    # The text passes over that probe and succeeds at the next direction.
    [(_, _, text_end)] = text.moves(m)
    np.testing.assert_allclose(text_end, R * DIRECTIONS[5], atol=1e-12)


def test_first_helper_takes_the_helper_nearest_the_target_not_the_shortest_sum():
    # SOURCE_SCENE and H2: at the probe of delta 3, direction 0, both B (1) and H2 (4) are
    # sweet and in sight. B is nearer the target; H2 gives the shorter q -> h -> target.
    scene = np.vstack([SOURCE_SCENE, [5.5, -1.5, 2.0]])
    evaluation = evaluate(make_swarm(scene, radius=R), load_sensor(), "shortest-length")
    m = pair_index(evaluation, 0, 2)
    probe = 3 * R * DIRECTIONS[0]

    def tracking(a, b):
        return np.linalg.norm(a - b) - 2 * R

    target = scene[2]
    assert tracking(scene[1], target) < tracking(scene[4], target)
    assert tracking(probe, scene[4]) + tracking(scene[4], target) < tracking(
        probe, scene[1]
    ) + tracking(scene[1], target)
    text = move_source(evaluation, 10)
    first = move_source(evaluation, 10, Compat(first_helper=True))
    assert text.paths.path(m) == [0, 4, 2] and first.paths.path(m) == [0, 1, 2]
    for result in (text, first):
        np.testing.assert_allclose(result.moves(m)[0][2], probe, atol=1e-12)


def test_collisions_near_origin_ignores_an_fls_beyond_t_plus_2_r_of_the_source():
    # With grid steps the probe (-1, -1, -1) of delta 2 is sqrt(3) cm from the source. An
    # FLS at (-1.5, -1.5, -1.5) is 0.87 cm from that probe, a collision (< 2r), but
    # 2.6 cm from the source, beyond (T + 2) r = 2 cm.
    collider = np.full(3, -1.5)
    scene = np.vstack([SOURCE_SCENE, collider])
    evaluation = evaluate(make_swarm(scene, radius=R), load_sensor(), "shortest-length")
    m = pair_index(evaluation, 0, 2)
    counted = move_source(evaluation, 2, Compat(grid_steps=True))
    near = move_source(evaluation, 2, Compat(grid_steps=True, collisions_near_origin=True))
    [(_, _, end)] = near.moves(m)
    np.testing.assert_allclose(end, [-1.0, -1.0, -1.0], atol=1e-12)
    assert np.linalg.norm(end - collider) < 2 * R < (2 + 2) * R < np.linalg.norm(collider)
    # Counted everywhere, the collision kills that direction; the next grid step succeeds.
    [(_, _, counted_end)] = counted.moves(m)
    np.testing.assert_allclose(counted_end, [-1.0, -1.0, 1.0], atol=1e-12)


def test_occlusion_near_origin_ignores_obstructers_far_from_the_source_on_the_chess_piece():
    # A probe's sight line is checked only against FLSs within |q - p_h| + 2r of the
    # source's place; an obstructer near a helper far from the source can lie beyond.
    swarm = make_swarm(load_cloud(dataset("chess_408.xyz")).points, beta=0.5)
    evaluation = evaluate(swarm, load_sensor(), "shortest-length")
    text = move_source(evaluation, 10)
    near = move_source(evaluation, 10, Compat(occlusion_near_origin=True))
    assert (text.resolved.sum(), near.resolved.sum()) == (11_095, 11_292)
    assert not (text.resolved & ~near.resolved).any()
    from swazure_ros.core.sight import obstructers

    only_near = np.flatnonzero(near.resolved & ~text.resolved)
    checked = 0
    for pair in only_near[:20].tolist():
        source, helper, _ = near.paths.path(pair)
        [(_, origin, probe)] = near.moves(pair)
        moved = swarm.points.copy()
        moved[source] = probe
        offsets, ids = obstructers(moved, swarm.radius, [source], [helper])
        if offsets[1] == 0:
            continue  # resolved earlier than the text found this probe; its sight is clear
        reach = np.linalg.norm(probe - swarm.points[helper]) + 2 * swarm.radius
        assert (np.linalg.norm(swarm.points[ids] - origin, axis=1) > reach).all()
        checked += 1
    assert checked > 0


@pytest.mark.parametrize("technique", [MOVE_OBSTRUCTING, MOVE_SOURCE])
def test_a_folded_run_keeps_each_resolved_pairs_path_and_the_others_plain(technique):
    swarm = make_swarm(load_cloud("torus:300").points, beta=0.5)
    evaluation = evaluate(swarm, load_sensor(), "shortest-length")
    folded, heuristic = run_technique(evaluation, technique, 10)
    resolved = heuristic.resolved
    assert resolved.any() and not resolved.all()
    for m in range(len(resolved)):
        expected = heuristic.paths.path(m) if resolved[m] else evaluation.pairs.path(m)
        assert folded.pairs.path(m) == expected


def test_an_obstructer_centred_on_its_hop_steps_r_aside_in_the_fixed_direction(sensor):
    # Every point of its circle is as near: the text and the published code take the same
    # fixed one, where the reference divides by zero (cube:64 at scale 4, beta 0.4, had one).
    evaluation = evaluate(blocked_scene(MIDPOINT), sensor, "shortest-length")
    m = pair_index(evaluation, 0, 2)
    aside = fixed_axis((B - A) / np.linalg.norm(B - A))
    for compat, reach in ((PUBLISHED, R), (Compat(), R * (1 + 1e-9))):
        result = move_obstructing(evaluation, compat)
        [(fls, start, end)] = result.moves(m)
        assert fls == 3 and result.resolved[m]
        np.testing.assert_array_equal(start, MIDPOINT)
        np.testing.assert_allclose(end, MIDPOINT + reach * aside, atol=1e-12)
