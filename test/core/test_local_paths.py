"""Decaying paths searched near their pairs are the paths SD_vis held whole gives."""

import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from swazure_ros.core import local_paths
from swazure_ros.core.blocks import BlockedEvaluation, Budget, evaluate_blocked, with_decaying
from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.compat import COMPAT_MODES
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.heuristics.regions import TechniqueBlocks
from swazure_ros.core.local_paths import (
    WIDER,
    _OnPaths,
    _slack,
    _stepped,
    least_cost_per_cm,
    local_decaying_paths,
    longest_edge,
)
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import neighbour_pairs, ordered_blind_pairs, pair_counts
from swazure_ros.core.pair_statistics import PairTally
from swazure_ros.core.path_arrays import Paths
from swazure_ros.core.paths import shortest_paths
from swazure_ros.core.pipeline import RunOptions, run_engine
from swazure_ros.core.progress import SILENT
from swazure_ros.core.sensor import DECAYING
from swazure_ros.files.results import write_evaluation, write_pair_blocks

from ..conftest import SCENE
from .test_blocks import assert_same_pairs, joined
from .test_regions import CASES, assert_same_pairs_but_moves, untimed

POLICIES = ["shortest-length", "fewest-hops"]


def plane(side=40, spacing=4.0, seed=7):
    """A jittered square grid ``side`` FLSs a side, 4 cm apart (156 cm wide, five sensor
    reaches): some blind pairs have no sweet path in sight, and a region near a pair is a
    part of the plane, not all of it. Seeded."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(side) * spacing, np.arange(side) * spacing)
    points = np.column_stack([x.ravel(), y.ravel(), np.zeros(side * side)])
    points[:, :2] += rng.uniform(-1.2, 1.2, size=(side * side, 2))
    return make_swarm(points, radius=0.5)


def apart_in_sight(hood):
    """The ordered blind pairs whose ends lie in two parts of S_vis."""
    source, target = ordered_blind_pairs(hood.pairs)
    parts = hood.sweet_visible_components
    apart = parts[source] != parts[target]
    return source[apart], target[apart]


def sd_vis_balls(sensor, policy, swarm):
    """SD_vis's paths between the pairs apart in S_vis of ``swarm``, and the radius about
    its source that each path's nodes lie in (``(cost / ratio + spread) / 2``)."""
    hood = neighbourhood(swarm, sensor)
    source, target = apart_in_sight(hood)
    paths = shortest_paths(hood.any_visible, source, target, policy)
    ratio = least_cost_per_cm(sensor, swarm.radius, policy)
    cost = paths.hops if policy == "fewest-hops" else paths.length
    spread = np.linalg.norm(swarm.points[target] - swarm.points[source], axis=1)
    return hood, source, target, paths, ratio, (cost / ratio + spread) / 2


def assert_same_paths(got: Paths, want: Paths):
    for name in ("found", "hops", "offsets", "nodes"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    np.testing.assert_array_equal(got.length, want.length, err_msg="length")  # NaN as NaN


@pytest.mark.parametrize("policy", POLICIES)
def test_no_edge_of_sd_vis_costs_less_a_cm_than_the_bound(sensor, policy):
    hood = neighbourhood(plane(), sensor)
    graph = hood.any_visible
    least = graph.reach_ratio(hops=policy == "fewest-hops")
    assert 0 < least_cost_per_cm(sensor, hood.swarm.radius, policy) <= least


@pytest.mark.parametrize("policy", POLICIES)
def test_no_hop_of_a_path_is_longer_than_its_ball_allows(sensor, policy):
    swarm = plane()
    hood, source, _, paths, ratio, ball = sd_vis_balls(sensor, policy, swarm)
    longest = np.zeros(len(source))
    for m in np.flatnonzero(paths.found):
        nodes = paths.path(m)
        hops = hood.pairs.index(
            np.minimum(nodes[:-1], nodes[1:]), np.maximum(nodes[:-1], nodes[1:])
        )
        longest[m] = hood.pairs.tracking[hops].max()
    bound = np.array([longest_edge(policy, ratio, swarm.radius, radius) for radius in ball])
    assert paths.found.sum() > 20 and (longest < bound).all()
    if policy == "shortest-length":
        # Tight enough to matter: the first region's bound leaves out most decaying pairs.
        assert (longest > 0.8 * bound)[paths.found].any()
        assert bound.min() < sensor.decaying_max / 2


@pytest.mark.parametrize("policy", POLICIES)
def test_every_hop_of_a_path_is_found_in_its_sources_ball_and_some_barely(sensor, policy):
    swarm = plane()
    _, source, _, paths, ratio, ball = sd_vis_balls(sensor, policy, swarm)
    every, short = np.arange(swarm.size), 0

    def kept_pairs(slack):
        on_paths = _OnPaths(policy, ratio, slack, swarm.radius)
        kept = neighbour_pairs(swarm, sensor, affordable=on_paths.affordable(every))
        return set(zip(kept.first.tolist(), kept.second.tolist(), strict=True))

    found = np.flatnonzero(paths.found)
    assert len(found) > 20
    for m in found[::4]:
        nodes = paths.path(m)
        ends = np.minimum(nodes[:-1], nodes[1:]), np.maximum(nodes[:-1], nodes[1:])
        hops = set(zip(ends[0].tolist(), ends[1].tolist(), strict=True))
        # A region of this one source, as wide as its path needs; and 1 % narrower.
        slack = ball[m] - np.linalg.norm(swarm.points - swarm.points[source[m]], axis=1)
        assert hops <= kept_pairs(slack)
        short += not hops <= kept_pairs(slack - 0.01 * ball[m])
    if policy == "shortest-length":
        # Tight: some path loses a hop when its ball is 1 % narrower (fewest-hops' bound,
        # a hop per sensor's reach, is loose).
        assert short > 0


def test_least_error_has_no_bound_and_is_not_searched_near_its_pairs(sensor):
    swarm = plane(side=6)
    assert least_cost_per_cm(sensor, swarm.radius, "least-error") == 0.0
    hood = neighbourhood(swarm, sensor)
    none = np.zeros(0, dtype=np.int64)
    counts = pair_counts(swarm, sensor)
    with pytest.raises(ValueError, match="least-error"):
        local_decaying_paths(hood, "least-error", none, none, counts, 10**9, SILENT)


@pytest.mark.parametrize("policy", POLICIES)
def test_paths_searched_near_their_pairs_are_those_of_sd_vis_held_whole(sensor, policy):
    swarm = plane()
    hood = neighbourhood(swarm, sensor)
    source, target = apart_in_sight(hood)
    assert len(source) > 20  # the premise: pairs that need a decaying path
    want = shortest_paths(hood.any_visible, source, target, policy)
    # Regions of a few hundred FLSs' candidates: many regions, each a part of the plane.
    counts = pair_counts(swarm, sensor)
    near = local_decaying_paths(hood, policy, source, target, counts, 40 * 200, SILENT)
    assert near.regions >= 3
    # Each pair judged once at most, and only those short and near enough to be on a path
    # (fewest-hops' regions are as wide as the sensor's reach: whole).
    assert near.judged <= hood.pairs.count(DECAYING) // (100 if policy == "shortest-length" else 1)
    assert_same_paths(near.paths, want)
    # Every decaying pair a path hops over is kept, once, and no other.
    first, second = near.hopped.first, near.hopped.second
    assert (near.hopped.range_class == DECAYING).all()
    assert len(np.unique(first * swarm.size + second)) == len(first)
    hops = {
        tuple(sorted(pair))
        for m in np.flatnonzero(want.found)
        for pair in zip(want.path(m)[:-1], want.path(m)[1:], strict=True)
    }
    ends = np.array(sorted(hops))
    classes = hood.pairs.range_class[hood.pairs.index(ends[:, 0], ends[:, 1])]
    decaying = {tuple(pair) for pair in ends[classes == DECAYING].tolist()}
    assert set(zip(first.tolist(), second.tolist(), strict=True)) == decaying


@pytest.mark.parametrize("policy", POLICIES)
def test_regions_searched_side_by_side_give_what_one_at_a_time_gives(sensor, policy, monkeypatch):
    swarm = plane()
    hood = neighbourhood(swarm, sensor)
    source, target = apart_in_sight(hood)
    counts = pair_counts(swarm, sensor)
    runs = []
    for at_once in (1, 2, 3):
        monkeypatch.setattr(local_paths, "REGIONS_AT_ONCE", at_once)
        runs.append(local_decaying_paths(hood, policy, source, target, counts, 40 * 200, SILENT))
    one = runs[0]
    assert one.regions >= 3  # the premise: several regions, so some ran side by side
    for other in runs[1:]:
        assert_same_paths(other.paths, one.paths)
        assert (other.rounds, other.regions, other.judged) == (one.rounds, one.regions, one.judged)
        assert np.array_equal(other.radius, one.radius)
        for name in ("first", "second", "distance", "range_class"):
            assert np.array_equal(getattr(other.hopped, name), getattr(one.hopped, name))


def test_a_path_its_first_region_cannot_prove_is_searched_again_a_step_wider(sensor):
    swarm = plane(seed=0)  # a plane where a narrow region's detours are long
    hood, source, target, want, _, needs = sd_vis_balls(sensor, "shortest-length", swarm)
    # The first margin is what two sweet hops need; a path with a decaying hop costs more.
    counts = pair_counts(swarm, sensor)
    near = local_decaying_paths(hood, "shortest-length", source, target, counts, 8000, SILENT)
    assert near.rounds >= 2 and (want.length > 16.0).any()
    assert_same_paths(near.paths, want)
    # Each pair is proven in the first region as wide as its path needs, or in one at
    # most a step wider than the last that was not (a longer path a narrow region found
    # is no measure of what SD_vis's needs).
    first = near.radius.min()
    assert (near.radius > first).sum() > 10
    assert (near.radius >= needs).all()
    assert (near.radius[near.radius > first] <= _stepped(WIDER * needs)[near.radius > first]).all()


def test_a_pair_the_swarm_does_not_join_is_proven_apart_near_it(sensor):
    # A and C are blind to each other, alone; a second swarm 500 cm off keeps the regions
    # from holding every FLS, so only the proof that A's part is closed ends the search.
    far = plane(side=8).points + np.array([500.0, 0.0, 0.0])
    swarm = make_swarm(np.vstack([SCENE[[0, 2]], far]), radius=0.5)
    hood = neighbourhood(swarm, sensor)
    source, target = np.array([0, 1]), np.array([1, 0])
    want = shortest_paths(hood.any_visible, source, target, "shortest-length")
    counts = pair_counts(swarm, sensor)
    near = local_decaying_paths(hood, "shortest-length", source, target, counts, 10**9, SILENT)
    assert not near.paths.found.any()
    assert near.rounds >= 2  # the first margin is within a reach of A: nothing proven
    assert_same_paths(near.paths, want)


@pytest.mark.parametrize("policy", POLICIES)
def test_blocks_searching_near_their_pairs_never_hold_sd_vis_and_give_the_whole_run(
    sensor, policy
):
    swarm = plane()
    whole = evaluate(swarm, sensor, policy)
    run = evaluate_blocked(swarm, sensor, policy, Budget(2**20), SILENT, near_pairs=True)
    assert run.lean.whole is None  # the decaying pairs do not fit the budget at once
    run.tally = PairTally()  # exact quantiles, whatever the budget
    blocks = list(run.blocks(SILENT))
    assert len(blocks) > 2
    assert_same_pairs(joined(blocks), whole.pairs)
    assert run.lean.whole is None and run.near is not None
    # What the run held of SD_vis: the decaying pairs the paths hop over, counted.
    held = run.hood.pairs.count(DECAYING)
    assert held == len(run.near.found.hopped) < whole.hood.pairs.count(DECAYING) // 10
    summary = replace(run.summary(), seconds=None).as_document()
    assert summary == replace(whole.summary, seconds=None).as_document()


def test_a_run_that_reads_more_of_sd_vis_holds_it_whole(sensor):
    swarm = plane()
    run = evaluate_blocked(swarm, sensor, "least-error", Budget(2**20), SILENT, near_pairs=True)
    list(run.blocks(SILENT))
    assert run.near is None and run.lean.whole is not None
    plain = evaluate_blocked(swarm, sensor, "fewest-hops", Budget(2**20), SILENT)
    assert isinstance(plain, BlockedEvaluation) and not plain.near_pairs
    list(plain.blocks(SILENT))
    assert plain.near is None and plain.lean.whole is not None


@pytest.mark.parametrize(("technique", "threshold", "compat"), CASES)
def test_a_heuristic_on_blocks_that_searched_near_their_pairs_gives_the_held_run(
    tmp_path, sensor, technique, threshold, compat
):
    # A heuristic reads the sweet graphs and the plain pairs' own paths, not SD_vis.
    swarm = plane()
    whole = evaluate(swarm, sensor, "shortest-length")
    held, moves = run_technique(whole, technique, threshold, COMPAT_MODES[compat])
    plain = evaluate_blocked(swarm, sensor, "shortest-length", Budget(2**20), SILENT, True)
    run = TechniqueBlocks(plain, technique, threshold, COMPAT_MODES[compat])
    run.tally = PairTally()  # exact quantiles, whatever the budget
    blocks = list(run.blocks(SILENT))
    assert plain.near is not None and plain.lean.whole is None
    assert sum(block.heuristic.resolved.any() for block in blocks) >= 2
    assert_same_pairs_but_moves(blocks, held.pairs)
    assert untimed(run.summary()) == untimed(held.summary)
    _, want = write_evaluation(tmp_path, held, moves)
    got = write_pair_blocks(tmp_path / "blocks", plain.hood, "shortest-length", iter(blocks))
    assert want is not None and got is not None and got.read_bytes() == want.read_bytes()


@pytest.mark.parametrize(
    ("options", "holds_sd_vis"),
    [
        (RunOptions(decaying="held"), True),
        (RunOptions(decaying="near"), False),
        (RunOptions(technique="move-obstructing", decaying="near"), False),
        (RunOptions(), False),
        (RunOptions(technique="move-source"), False),
        (RunOptions(fuse=2), True),
        (RunOptions(policy="least-error"), True),
    ],
    ids=[
        "plain-held",
        "plain-near",
        "move-obstructing-near",
        "plain",
        "move-source",
        "fuse",
        "least-error",
    ],
)
def test_run_engine_holds_sd_vis_only_where_a_search_near_the_pairs_cannot_serve(
    sensor, monkeypatch, options, holds_sd_vis
):
    import swazure_ros.core.blocks as blocks

    whole = []
    monkeypatch.setattr(
        blocks,
        "with_decaying",
        lambda lean, progress: whole.append(lean) or with_decaying(lean, progress),
    )
    swarm = plane()
    run = run_engine(swarm, sensor, options, budget=Budget(8 * 2**20))  # not at once
    held = run_engine(swarm, sensor, options, hold=True)
    assert bool(whole) == holds_sd_vis
    assert without_seconds(run.summary.as_document()) == without_seconds(
        held.summary.as_document()
    )


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (RunOptions(fuse=2, decaying="near"), "fusion and the fits"),
        (RunOptions(estimator="least-squares", decaying="near"), "fusion and the fits"),
        (RunOptions(policy="least-error", decaying="near"), "fewest-hops or shortest-length"),
        (RunOptions(decaying="nearby"), "decaying 'nearby'"),
    ],
)
def test_a_search_near_the_pairs_is_refused_where_it_cannot_be_proven(sensor, options, message):
    with pytest.raises(SwazureError, match=message):
        options.check()


def without_seconds(document):
    """A summary's document without the times of its stages, at any depth."""
    if isinstance(document, dict):
        return {key: without_seconds(value) for key, value in document.items() if key != "seconds"}
    return document


def test_regions_that_overlap_are_cut_only_when_far_over_the_budget(sensor):
    from swazure_ros.core.local_paths import OVERLOADED, _tiles, _Weights

    swarm = plane()
    hood = neighbourhood(swarm, sensor)
    counts = pair_counts(swarm, sensor)
    weights = _Weights(
        hood, "shortest-length", least_cost_per_cm(sensor, 0.5, "shortest-length"), counts
    )
    sources = np.arange(0, swarm.size, 67)  # spread over the plane
    wide = np.full(len(sources), 70.0)  # balls of 70 cm on a plane 156 cm wide
    # The balls hold every FLS, and pairs up to the sensor's reach but the blind ones, which
    # no region holds: the swarm's candidates less its blind pairs (6 % of them here),
    # weighed round a sample of the FLSs.
    blind = np.count_nonzero(hood.pairs.tracking < sensor.sweet_min)
    assert weights(70.0) == pytest.approx(2.0 * (counts.sum() - blind) / swarm.size, rel=0.02)
    assert weights(12.0) < weights(70.0) / 2  # a narrow region holds the shorter pairs only
    whole = weights(70.0) * swarm.size
    # Halves as heavy as the whole together: not worth cutting within twice the budget ...
    assert len(_tiles(swarm.points, sources, wide, weights, int(whole / OVERLOADED) + 1)) == 1
    # ... and cut, each region lighter, when far over it.
    groups = _tiles(swarm.points, sources, wide, weights, int(whole / (2 * OVERLOADED)))
    assert len(groups) > 1
    assert sorted(np.concatenate(groups).tolist()) == sources.tolist()


def test_each_fls_lies_as_far_inside_its_deepest_ball_as_measured_and_outside_none():
    # Balls of three radii about four FLSs of a plane; FLSs in no ball have no slack, those
    # just at a ball's edge a slack of about 0 (the bound is a hair over the radius).
    points = plane(side=20).points  # 76 cm wide
    centres = np.array([0, 45, 210, 399])
    radii = np.array([10.0, 10.0, 16.0, 4.0])
    slack = _slack(points, centres, radii)
    depth = radii[None, :] - np.linalg.norm(points[:, None] - points[centres][None], axis=2)
    inside = depth >= -1e-6 * radii[None, :]
    expected = np.where(inside.any(axis=1), np.where(inside, depth, -np.inf).max(axis=1), -np.inf)
    assert np.isinf(slack).sum() == np.isinf(expected).sum() > 300  # most FLSs in no ball
    assert np.allclose(slack[np.isfinite(expected)], expected[np.isfinite(expected)])
    assert (slack[centres] == radii).all()


#: Decaying paths near their pairs in a process of their own, numba's layer as its
#: environment says; prints the regions searched.
ON_A_LAYER = """
import numpy as np
from swazure_ros.core.local_paths import local_decaying_paths
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.neighbours import pair_counts
from swazure_ros.core.progress import SILENT
from swazure_ros.core.sensor import Sensor
from test.core.test_local_paths import apart_in_sight, plane

sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755), "published")
swarm = plane()
hood = neighbourhood(swarm, sensor)
source, target = apart_in_sight(hood)
near = local_decaying_paths(
    hood, "shortest-length", source, target, pair_counts(swarm, sensor), 40 * 200, SILENT
)
print(near.regions, int(near.paths.found.sum()))
"""


def test_regions_are_searched_one_at_a_time_where_numba_s_layer_is_not_threadsafe():
    # Two regions at once would start parallel kernels on two threads, which numba's
    # workqueue answers by ending the process (SIGABRT).
    root = Path(__file__).resolve().parents[2]
    runs = {}
    for layer in ("workqueue", "omp"):
        environment = {**os.environ, "NUMBA_THREADING_LAYER": layer}
        done = subprocess.run(
            [sys.executable, "-c", ON_A_LAYER],
            capture_output=True, text=True, timeout=600, env=environment, cwd=root,
        )  # fmt: skip
        if layer == "omp" and "No threading layer could be loaded" in done.stderr:
            continue  # no OpenMP runtime on this machine: workqueue alone is judged
        assert done.returncode == 0, done.stderr[-2000:]
        runs[layer] = done.stdout.split()
    regions, found = (int(value) for value in runs["workqueue"])
    assert regions >= 3 and found > 20
    assert runs.get("omp", runs["workqueue"]) == runs["workqueue"]
