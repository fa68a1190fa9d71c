"""The swarm's conjugate gradients: sums over the swarm, exact in any order."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swazure_ros.core.conjugate_gradients import partial_dot, swarm_sum


def test_the_swarm_s_sums_are_the_same_in_any_order():
    rng = np.random.default_rng(4)
    one, other = rng.normal(size=(500, 3, 2)) * 1e6, rng.normal(size=(500, 3, 2))
    shares = partial_dot(one, other)
    shuffled = shares[rng.permutation(500)]
    assert swarm_sum(shares).tolist() == swarm_sum(shuffled).tolist()


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
