"""Runs compared (core.compare): the summaries' rows, the classes side by side, refusals."""

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.compare import compare, method
from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.metric_rows import METRICS, metric_row
from swazure_ros.core.pair_classes import PairErrors
from swazure_ros.core.summary import Source

from ..conftest import scene

A, B, C, K, D = 0, 1, 2, 3, 4


def summary_of(cloud="scene", technique_evaluation=None, sensor=None):
    evaluation = technique_evaluation or evaluate(scene(A, B, C, K, D), sensor, "fewest-hops")
    summary = evaluation.summary
    source = Source(cloud, "hand-built", 1.0, 0, "config/sensor.yaml")
    return replace(summary, parameters=replace(summary.parameters, source=source))


def test_metric_row_gives_deltas_from_the_first_and_the_best(sensor):
    plain = summary_of(sensor=sensor)  # every pair on a decaying path: no path 0 %
    worse = replace(plain, pairs=replace(plain.pairs, no_path_pct=25.0))
    no_path = next(metric for metric in METRICS if metric.label == "no path, %")
    row = metric_row(no_path, [worse, plain, worse])
    assert row.values == (25.0, 0.0, 25.0) and row.deltas == (0.0, -25.0, 0.0)
    assert row.best == (1,) and row.margin == -25.0
    # A number with no better direction is shown, never judged.
    pairs = next(metric for metric in METRICS if metric.label == "ordered blind pairs")
    assert metric_row(pairs, [worse, plain]).best == ()


def test_compare_refuses_fewer_than_two_runs_one_label_twice_and_two_clouds(sensor):
    summary = summary_of(sensor=sensor)
    with pytest.raises(SwazureError, match="two or more runs, got 1"):
        compare([("a", summary, None)])
    with pytest.raises(SwazureError, match="runs given twice: a"):
        compare([("a", summary, None), ("a", summary, None)])
    other = summary_of("dragon_1147", sensor=sensor)
    with pytest.raises(SwazureError, match=r"different clouds: a \(scene\), b \(dragon_1147\)"):
        compare([("a", summary, None), ("b", other, None)])


def test_compare_puts_summaries_and_classes_side_by_side(sensor):
    summary = summary_of(sensor=sensor)
    errors = PairErrors(np.array([0, 1], np.uint8), np.array([0.1, np.nan]), "cm")
    better = PairErrors(np.array([0, 1], np.uint8), np.array([0.1, 0.2]), "cm")
    comparison = compare([("a", summary, errors), ("b", summary, better), ("c", summary, None)])
    assert [run.method for run in comparison.runs] == ["plain"] * 3 == [method(summary)] * 3
    assert comparison.runs[2].classes is None
    labels = [row.label for row in comparison.rows]
    assert "tried pairs" not in labels  # no run made moves: no such row
    assert "blocked: coverage, %" in [row.label for row in comparison.class_rows]
    verdicts = {verdict.pair_class: verdict for verdict in comparison.verdicts}
    assert set(verdicts) == {"all pairs", "sweet path", "blocked"}  # classes with pairs
    assert verdicts["blocked"].by_coverage == ((1,), (0,))
    assert verdicts["sweet path"].by_median == ((0, 1),)
