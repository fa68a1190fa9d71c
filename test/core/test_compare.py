"""Runs compared (core.compare): ranks and ties, results by class of pairs, verdicts, refusals."""

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.compare import (
    METRICS,
    PAIR_CLASSES,
    PairErrors,
    class_results,
    class_verdict,
    compare,
    method,
    metric_row,
    rank,
)
from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.summary import Source

from ..conftest import scene

A, B, C, K, D = 0, 1, 2, 3, 4


def test_rank_puts_the_best_first_and_groups_ties():
    assert rank([3.0, 1.0, None, 2.0], "lower") == ((1,), (3,), (0,))
    assert rank([3.0, 1.0, None, 2.0], "higher") == ((0,), (3,), (1,))
    # Within 1e-4 of each other (relative): one group, in the runs' order.
    assert rank([2.0, 1.0, 1.00000001, 5.0], "lower") == ((1, 2), (0,), (3,))
    assert rank([None, None], "lower") == ()


def test_rank_refuses_a_number_without_a_better_direction():
    with pytest.raises(ValueError, match="better must be 'lower' or 'higher'"):
        rank([1.0, 2.0], "neither")


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


def test_class_results_count_coverage_and_errors_per_class():
    # Classes by reason code: 0 sweet path, 1 blocked, 2 no sweet path.
    errors = PairErrors(
        np.array([0, 0, 0, 1, 1, 2], np.uint8),
        np.array([1.0, 2.0, 6.0, 4.0, np.nan, np.nan]),
        "cm",
    )
    results = {result.pair_class: result for result in class_results(errors)}
    assert [r.pair_class for r in class_results(errors)] == list(PAIR_CLASSES)
    assert (results["all pairs"].pairs, results["all pairs"].estimated) == (6, 4)
    assert results["sweet path"].median == 2.0 and results["sweet path"].mean == 3.0
    assert results["blocked"].coverage_pct == 50.0 and results["blocked"].median == 4.0
    assert results["no sweet path"].coverage_pct == 0.0
    assert results["no sweet path"].median is None and results["no sweet path"].cdf == ()
    assert results["aborted"].pairs == 0 and results["aborted"].coverage_pct is None
    assert results["sweet path"].cdf[0] == 1.0 and results["sweet path"].cdf[-1] == 6.0


def test_class_results_refuse_arrays_of_two_shapes():
    with pytest.raises(ValueError, match="one shape"):
        class_results(PairErrors(np.zeros(3, np.uint8), np.zeros(2), "cm"))


def test_verdict_ranks_by_median_error_and_by_coverage():
    first = PairErrors(
        np.array([1, 1, 1, 1], np.uint8), np.array([0.5, 0.7, np.nan, np.nan]), "cm"
    )
    second = PairErrors(np.array([1, 1, 1, 1], np.uint8), np.array([0.1, 0.2, 0.3, np.nan]), "cm")
    blocked = PAIR_CLASSES.index("blocked")
    verdict = class_verdict(
        ["a", "b"],
        [class_results(first)[blocked], class_results(second)[blocked]],
        "cm",
    )
    assert verdict.by_median == ((1,), (0,)) and verdict.by_coverage == ((1,), (0,))
    assert verdict.statement == (
        "blocked (4 pairs): by median error b 0.2 < a 0.6 cm; by coverage b 75 > a 50 %"
    )


def test_verdict_says_who_estimates_none_and_ties():
    none = PairErrors(np.array([1, 1], np.uint8), np.array([np.nan, np.nan]), "cm")
    some = PairErrors(np.array([1, 1], np.uint8), np.array([0.3, 0.3]), "cm")
    blocked = PAIR_CLASSES.index("blocked")
    results = [class_results(errors)[blocked] for errors in (none, some, some)]
    verdict = class_verdict(["a", "b", "c"], results, "cm")
    assert verdict.by_median == ((1, 2),)
    assert "by median error b 0.3 = c 0.3 cm (a: none estimated)" in verdict.statement
    assert "by coverage b 100 = c 100 > a 0 %" in verdict.statement
    assert class_verdict(["a", "b"], results[:1] * 2, "cm").statement.endswith(
        "no run estimates any; by coverage all 0 %"
    )


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
