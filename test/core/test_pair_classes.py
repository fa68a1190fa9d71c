"""The pairs by class (core.pair_classes): results per class, verdicts."""

import numpy as np
import pytest

from swazure_ros.core.pair_classes import PAIR_CLASSES, PairErrors, class_results, class_verdict


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
