"""Statistics gathered block by block: those of all values at once, or within a bound."""

import math

import numpy as np
import pytest

from swazure_ros.core.metrics import describe
from swazure_ros.core.tally import SKETCH_RELATIVE_ERROR, IntegerTally, RealTally


def blocks_of(values, sizes):
    """``values`` cut into consecutive blocks of the given sizes (the rest last)."""
    cuts = np.cumsum(sizes)
    return np.split(values, cuts[cuts < len(values)])


@pytest.mark.parametrize("sizes", [[10_000], [1, 2, 3, 500], [7] * 40])
def test_integer_tally_is_describe_of_every_value(sizes):
    values = np.random.default_rng(3).integers(0, 13, size=1_000)
    tally = IntegerTally()
    for block in blocks_of(values, sizes):
        tally.add(block)
    assert tally.describe() == describe(values)


def test_integer_tally_of_nothing_is_describe_of_nothing():
    tally = IntegerTally()
    tally.add(np.zeros(0, dtype=np.int64))
    assert tally.describe() == describe([])


def test_real_tally_within_its_bound_is_describe_of_every_value():
    values = np.random.default_rng(4).lognormal(size=5_000)
    tally = RealTally(exact_values=5_000)
    for block in blocks_of(values, [1_000, 17, 3_000]):
        tally.add(block)
    assert tally.exact
    assert tally.describe() == describe(values)


def test_real_tally_past_its_bound_sketches_quantiles_within_the_relative_error():
    values = np.random.default_rng(5).lognormal(sigma=2.0, size=50_000)
    values[:100] = 0.0  # exact estimates of an error-free sensor
    tally = RealTally(exact_values=10_000)
    for block in blocks_of(values, [4_000] * 20):
        tally.add(block)
    assert not tally.exact
    got, want = tally.describe(), describe(values)
    assert got.count == want.count and got.max == want.max
    assert math.isclose(got.mean, want.mean, rel_tol=1e-12)
    ordered = np.sort(values)
    for name, quantile in (("p50", 0.5), ("p90", 0.9), ("p99", 0.99)):
        # Between the two order statistics numpy interpolates, each within the bound.
        position = quantile * (len(values) - 1)
        low, high = ordered[math.floor(position)], ordered[math.ceil(position)]
        bound = 2 * SKETCH_RELATIVE_ERROR
        assert low * (1 - bound) <= getattr(got, name) <= high * (1 + bound), name


def test_real_tally_with_an_unknown_value_reports_unknown_statistics():
    tally = RealTally(exact_values=1)
    tally.add(np.array([1.0, np.nan, 2.0]))
    got = tally.describe()
    assert got.count == 3
    assert all(math.isnan(getattr(got, name)) for name in ("mean", "max", "p50", "p90", "p99"))


def test_a_sketch_counts_each_value_in_the_bucket_whose_range_holds_it():
    # Bucket k holds the values in (gamma ** (k - 1), gamma ** k], block after block.
    values = np.random.default_rng(6).lognormal(sigma=3.0, size=20_000)
    values[:50] = 0.0  # counted apart, as zeros
    tally = RealTally(exact_values=1)  # sketched from the first block on
    for block in blocks_of(values, [3_000] * 7):
        tally.add(block)
    gamma = (1 + SKETCH_RELATIVE_ERROR) / (1 - SKETCH_RELATIVE_ERROR)
    want: dict[int, int] = {}
    for value in values[50:].tolist():
        key = math.ceil(math.log(value) / math.log(gamma))
        want[key] = want.get(key, 0) + 1
    assert tally.zeros == 50
    assert tally.buckets == want
    assert 1_000 < len(want) < len(values)  # values spread over many buckets, some shared
