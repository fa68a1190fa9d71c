"""Exact sums over the swarm: each column's math.fsum, to the bit, compiled or not."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swazure_ros.core.exact_sums import _exact_sums, swarm_sum


def fsum_bits(columns):
    """CPython's math.fsum of each column, as the bits of its double."""
    return np.array([math.fsum(column) for column in columns.T.tolist()]).view(np.int64)


# Any finite doubles, subnormals and signed zeros among them, and cancelling runs.
doubles = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(doubles, doubles), max_size=60), st.booleans())
def test_a_swarm_sum_is_math_fsum_to_the_bit(rows, cancelled):
    shares = np.array(rows, dtype=np.float64).reshape(-1, 2)
    if cancelled:
        shares = np.concatenate([shares, -shares[::-1], shares[:1] * 1e-300])
    try:
        want = fsum_bits(shares)
    except OverflowError:
        return  # CPython's own fsum says so; swarm_sum hands such sums to it
    assert swarm_sum(shares).view(np.int64).tolist() == want.tolist()


def test_a_swarm_sum_of_doubles_over_every_exponent_is_math_fsum_to_the_bit():
    # Many non-overlapping partials at once: more than the room an exact sum starts with.
    rng = np.random.default_rng(0)
    exponents = rng.permutation(np.arange(-1074, 1000, 7)).astype(float)
    shares = np.stack([2.0**exponents, -(2.0 ** exponents[::-1]) * 3.0], axis=1)
    assert swarm_sum(shares).view(np.int64).tolist() == fsum_bits(shares).tolist()


# Below 2^960 the compiled sum answers itself (above, CPython's fsum does).
moderate = st.floats(min_value=-(2.0**959), max_value=2.0**959, allow_nan=False, width=64)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(moderate, moderate), max_size=60), st.integers(1, 4), st.booleans())
def test_the_compiled_sum_carrying_every_few_shares_is_math_fsum_to_the_bit(
    rows, carry_every, cancelled
):
    shares = np.array(rows, dtype=np.float64).reshape(-1, 2)
    if cancelled:
        shares = np.concatenate([shares, -shares[::-1], shares[:1] * 1e-300])
    got = _exact_sums(np.ascontiguousarray(shares).view(np.int64), carry_every)
    assert got.view(np.int64).tolist() == fsum_bits(shares).tolist()


def test_a_compiled_sum_over_every_exponent_it_takes_is_math_fsum_to_the_bit():
    rng = np.random.default_rng(1)
    exponents = rng.permutation(np.arange(-1074, 960, 3)).astype(float)
    shares = np.stack([2.0**exponents * 1.75, -(2.0 ** exponents[::-1]) * 1.5], axis=1)
    shares = np.concatenate([shares, shares * -0.999999])
    assert swarm_sum(shares).view(np.int64).tolist() == fsum_bits(shares).tolist()


def test_a_sum_with_an_inf_or_a_nan_among_its_shares_is_math_fsum_s():
    shares = np.array([[np.inf, np.nan, 1.0], [2.0, 3.0, 2.0**-1074], [1.0, 4.0, -1.0]])
    want = [math.fsum(column) for column in shares.T.tolist()]
    got = swarm_sum(shares).tolist()
    assert got[0] == want[0] == np.inf and got[2] == want[2] == 2.0**-1074
    assert np.isnan(got[1]) and np.isnan(want[1])
