"""Counter-based draws: splitmix64 of the keys, the same bits compiled or interpreted."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from swazure_ros.core.draws import standard_normals, uniforms

from .interpreting import interpreted

BITS = (1 << 64) - 1
#: splitmix64's and the key mixing's constants, written out again as the oracle's.
SEED_MULTIPLIER = 0xD1B54A32D192ED03
KEY_MULTIPLIERS = (
    0x9E3779B97F4A7C15,
    0xBF58476D1CE4E5B9,
    0x94D049BB133111EB,
    0xD6E8FEB86659FD93,
    0xA0761D6478BD642F,
    0xE7037ED1A0B428DB,
)


def splitmix64(seed, keys, count):
    """The draws of one row by Python's integers, wrapped to 64 bits by hand."""
    base = (seed & BITS) * SEED_MULTIPLIER & BITS
    for key, multiplier in zip(keys, KEY_MULTIPLIERS, strict=False):
        base ^= (key & BITS) * multiplier & BITS
    row = []
    for step in range(1, count + 1):
        z = (base + step * 0x94D049BB133111EB) & BITS
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9 & BITS
        z = (z ^ (z >> 27)) * 0x94D049BB133111EB & BITS
        z ^= z >> 31
        row.append(((z >> 11) + 0.5) / 2.0**53)
    return row


int64s = st.integers(-(1 << 63), (1 << 63) - 1)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(-(1 << 64), 1 << 64),
    st.integers(1, 6).flatmap(lambda width: st.lists(st.tuples(*[int64s] * width), max_size=5)),
    st.integers(1, 9),
)
def test_uniforms_are_splitmix64_of_the_keys_compiled_or_interpreted(seed, rows, count):
    if not rows:
        return
    keys = [np.array(column, dtype=np.int64) for column in zip(*rows, strict=True)]
    want = [splitmix64(seed, row, count) for row in rows]
    assert uniforms(seed, keys, count).tolist() == want
    assert interpreted(uniforms, seed, keys, count).tolist() == want


def test_normals_are_the_same_bits_compiled_or_interpreted():
    # The swarm fit's draws in a packed process and in an FLS's own must agree.
    first, second = np.arange(300), np.arange(300)[::-1] * 7919
    compiled = standard_normals(11, [first, second], 192)
    assert compiled.tobytes() == interpreted(standard_normals, 11, [first, second], 192).tobytes()
    assert 0.9 < compiled.std() < 1.1  # normal: the draws are not all one number
