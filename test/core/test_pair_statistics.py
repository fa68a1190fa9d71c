"""The run's summary of its pairs (spec, section 6), on the hand-built scene and a torus."""

import pytest

from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import DECAYING_PATH, SWEET_PATH
from swazure_ros.core.geometry import make_swarm
from swazure_ros.files.cloud_files import load_cloud

from ..conftest import A, B, C, D, K, scene


def test_summary_counts_of_the_full_scene(sensor):
    summary = evaluate(scene(A, B, C, K, D), sensor, "fewest-hops").summary
    # Blind: A-C, A-K, B-K, C-K, both ways. Every one gets a decaying path via D.
    assert summary.pairs.blind_pairs == 8
    assert summary.pairs.decaying_pct == 100.0
    assert summary.pairs.blocked_pairs == 2
    assert summary.pairs.no_sweet_path_pairs == 6
    assert summary.pairs.obstructed_path_pct == 100.0  # the one S_all path, both ways
    assert summary.pairs.hops.mean == 2.0
    assert summary.kissing_pairs == 0
    for key in ("flss", "removed", "radius", "dmin", "seconds", "sweet_pct", "no_path_pct"):
        assert key in summary.as_document()


def test_summary_gives_the_distance_error_of_each_class_of_pair_apart(sensor):
    # The hand-built scene: every blind pair's path is decaying, none is sweet.
    summary = evaluate(scene(A, B, C, K, D), sensor, "fewest-hops").summary
    assert summary.pairs.distance_error_pct_sweet_paths.count == 0
    decaying = summary.pairs.distance_error_pct_decaying_paths
    assert decaying.count == 8 and decaying.mean == summary.pairs.distance_error_pct.mean
    # A torus whose pairs are both: each class's mean is over its own pairs alone.
    evaluation = evaluate(
        make_swarm(load_cloud("torus:120", 6.0).points, beta=0.5), sensor, "shortest-length"
    )
    pairs, summary = evaluation.pairs, evaluation.summary
    for status, key in ((SWEET_PATH, "sweet"), (DECAYING_PATH, "decaying")):
        errors = pairs.distance_error[pairs.status == status]
        assert len(errors) > 100
        stats = getattr(summary.pairs, f"distance_error_pct_{key}_paths")
        assert stats.mean == pytest.approx(errors.mean())
    sweet = summary.pairs.distance_error_pct_sweet_paths.mean
    assert sweet < summary.pairs.distance_error_pct.mean
