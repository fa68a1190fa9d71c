"""The swarm's scene: colours, example paths and moves agree with the evaluation behind them."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError, UnknownFlsError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import SWEET_PATH
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.sensors import load_sensor
from swazure_ros.view.scene import (
    CHOSEN,
    NO_BLIND,
    RANGE_COLOURS,
    SWEET_SHARE_BINS,
    evaluation_scene,
)
from swazure_ros.view.snapshot import write_snapshot


@pytest.fixture(scope="module")
def evaluation():
    # Beta 0.3: FLSs fall in three of the four bins of their share of sweet paths.
    swarm = make_swarm(load_cloud("torus:200").points, beta=0.3)
    return evaluate(swarm, load_sensor(), "shortest-length")


def test_status_colours_bin_each_flss_share_of_blind_neighbours_with_a_sweet_path(evaluation):
    scene = evaluation_scene(evaluation, "torus")
    pairs = evaluation.pairs
    lows = [low for low, _, _ in SWEET_SHARE_BINS]
    seen_bins = set()
    for index in range(evaluation.hood.swarm.size):
        mine = pairs.source == index
        if not mine.any():
            np.testing.assert_array_equal(scene.colours[index], NO_BLIND[1])
            continue
        share = np.mean(pairs.status[mine] == SWEET_PATH)
        bin_index = max(i for i, low in enumerate(lows) if share >= low)
        seen_bins.add(bin_index)
        np.testing.assert_array_equal(scene.colours[index], SWEET_SHARE_BINS[bin_index][2])
    assert len(seen_bins) >= 2  # the torus is not one colour
    counted = sum(int(label.split("(")[1].split()[0]) for label, _ in scene.legend)
    assert counted == evaluation.hood.swarm.size


def test_example_paths_are_sweet_paths_of_the_evaluation_from_few_to_many_hops(evaluation):
    scene = evaluation_scene(evaluation, "torus", paths=3)
    pairs, points = evaluation.pairs, evaluation.hood.swarm.points
    hops = []
    for path in scene.paths:
        source, target = (int(word) for word in path.label.split(",")[0][4:].split(" -> "))
        pair = np.flatnonzero((pairs.source == source) & (pairs.target == target))[0]
        assert pairs.status[pair] == SWEET_PATH
        nodes = pairs.nodes[pairs.offsets[pair] : pairs.offsets[pair + 1]]
        np.testing.assert_array_equal(path.points, points[nodes])
        hops.append(len(nodes) - 1)
    assert len(hops) >= 2 and hops == sorted(hops) and len(set(hops)) == len(hops)


def test_range_colours_are_the_range_classes_seen_from_the_seen_from(evaluation):
    chosen = 7
    scene = evaluation_scene(evaluation, "torus", colour_by="ranges", seen_from=chosen)
    hood = evaluation.hood
    assert scene.highlight == chosen  # the torus keeps every point: index = id
    np.testing.assert_array_equal(scene.colours[chosen], CHOSEN[1])
    mine = (hood.pairs.first == chosen) | (hood.pairs.second == chosen)
    for first, second, kind in zip(
        hood.pairs.first[mine], hood.pairs.second[mine], hood.pairs.range_class[mine], strict=True
    ):
        other = second if first == chosen else first
        if kind in RANGE_COLOURS:
            np.testing.assert_array_equal(scene.colours[other], RANGE_COLOURS[kind][1])
    for path in scene.paths:
        assert path.label.startswith(f"FLS {chosen} -> ")
    with pytest.raises(UnknownFlsError, match="no FLS 5000"):
        evaluation_scene(evaluation, "torus", colour_by="ranges", seen_from=5000)


def test_a_heuristics_moves_are_the_scenes_arrows(tmp_path):
    # Denser, at beta 0.5: Move Obstructing resolves pairs here.
    swarm = make_swarm(load_cloud("torus:120", 1.6).points, beta=0.5)
    evaluation = evaluate(swarm, load_sensor(), "shortest-length")
    moved, heuristic = run_technique(evaluation, "move-obstructing", 10)
    scene = evaluation_scene(moved, "torus", heuristic=heuristic)
    first = np.flatnonzero(heuristic.resolved)[:3]
    expected = [move for pair in first for move in heuristic.moves(int(pair))]
    assert len(scene.moves) == len(expected) > 0
    for (start, end), (_, want_start, want_end) in zip(scene.moves, expected, strict=True):
        np.testing.assert_array_equal(start, want_start)
        np.testing.assert_array_equal(end, want_end)
    path = write_snapshot(scene, tmp_path / "torus.png")
    assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["torus.png"]


def test_selected_pairs_paths_are_drawn_and_a_pair_that_is_not_blind_is_refused(evaluation):
    pairs = evaluation.pairs
    ids = evaluation.hood.swarm.cloud_index
    found = np.flatnonzero(pairs.hops >= 2)[:2]
    selected = [(int(ids[pairs.source[m]]), int(ids[pairs.target[m]])) for m in found]
    scene = evaluation_scene(evaluation, "torus", pairs=selected)
    assert [path.label.split(",")[0] for path in scene.paths] == [
        f"FLS {source} -> {target}" for source, target in selected
    ]
    for path, pair in zip(scene.paths, found, strict=True):
        nodes = pairs.nodes[pairs.offsets[pair] : pairs.offsets[pair + 1]]
        np.testing.assert_array_equal(path.points, evaluation.hood.swarm.points[nodes])
    with pytest.raises(SwazureError, match="FLS 0 -> 0 is not a blind pair"):
        evaluation_scene(evaluation, "torus", pairs=[(0, 0)])
