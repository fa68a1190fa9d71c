"""Counter-based random numbers: a draw fixed by a seed and integer keys, in any order.

A pair's sensor noise or a radio delivery's fate must be the same in the
engine and in every node, whichever computes it first, so it cannot come
from a stream. splitmix64 of the keys gives it, vectorised over arrays, or
compiled in one pass where this process compiles its kernels (the same bits:
integer arithmetic and exact conversions only).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import jit
from .arrays import FloatArray

# Odd constants of splitmix64 and of the key mixing (from the golden ratio and friends).
_MULTIPLIERS = (
    0xD1B54A32D192ED03,
    0x9E3779B97F4A7C15,
    0xBF58476D1CE4E5B9,
    0x94D049BB133111EB,
    0xD6E8FEB86659FD93,
    0xA0761D6478BD642F,
    0xE7037ED1A0B428DB,
)
#: splitmix64's increment (a number's step) and its two mixing multipliers.
_STEP = np.uint64(0x94D049BB133111EB)
_MIX_1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX_2 = np.uint64(0x94D049BB133111EB)


def uniforms(seed: int, keys: Sequence[ArrayLike], count: int) -> FloatArray:
    """Uniform numbers in (0, 1), shape (M, count), fixed by ``seed`` and each row's keys.

    The same seed and keys give the same numbers, whichever process draws
    them and in whatever order (splitmix64 of the keys, not a stream).

    Parameters
    ----------
    seed : int
    keys : sequence of array_like of int
        1 to 6 integer arrays of M values (broadcast), e.g. the measuring and
        the measured FLS. Their order matters.
    count : int
        Numbers per row.

    Returns
    -------
    (M, count) array of float
        In the open interval (0, 1), 53 bits each.

    Raises
    ------
    ValueError
        No key, or more than six.

    Examples
    --------
    >>> from swazure_ros.core.draws import uniforms
    >>> both = uniforms(7, [[0, 1], [1, 0]], 2)  # rows: the pairs (0, 1) and (1, 0)
    >>> bool((both[1] == uniforms(7, [[1], [0]], 2)[0]).all())  # a row alone, the same
    True
    """
    if not 1 <= len(keys) < len(_MULTIPLIERS):
        raise ValueError(f"uniforms takes 1 to {len(_MULTIPLIERS) - 1} keys, got {len(keys)}")
    columns = np.broadcast_arrays(*(np.asarray(key, dtype=np.int64).ravel() for key in keys))
    with np.errstate(over="ignore"):
        base: NDArray[np.uint64] = np.full(
            columns[0].shape, np.uint64(seed & 0xFFFFFFFFFFFFFFFF) * np.uint64(_MULTIPLIERS[0])
        )
        for column, multiplier in zip(columns, _MULTIPLIERS[1:], strict=False):
            base = base ^ (column.astype(np.uint64) * np.uint64(multiplier))
        base = np.ascontiguousarray(base, dtype=np.uint64).ravel()
        if not jit.INTERPRET:
            return _compiled_uniforms(base, count)
        steps = np.arange(1, count + 1, dtype=np.uint64) * _STEP
        z = base.reshape(-1, 1) + steps[None, :]
        z = (z ^ (z >> np.uint64(30))) * _MIX_1
        z = (z ^ (z >> np.uint64(27))) * _MIX_2
        z = z ^ (z >> np.uint64(31))
    return np.asarray(((z >> np.uint64(11)).astype(np.float64) + 0.5) / float(1 << 53))


@jit.kernel(cache=True, nogil=True)
def _compiled_uniforms(base: NDArray[np.uint64], count: int) -> FloatArray:
    """:func:`uniforms`' numbers from each row's mixed keys, in one pass (the same bits).

    numpy's passes over (M, count) arrays took 1.1 s for 19.2 M numbers, this
    0.15 s (measured 2026-12-01). Every step is an integer one or exact (a 53-bit
    integer, plus 0.5, over 2^53).
    """
    rows = base.shape[0]
    out = np.empty((rows, count), dtype=np.float64)
    for row in range(rows):
        z = base[row]
        for column in range(count):
            z = z + _STEP  # the column-th step, added once more each column (wrapping)
            mixed = (z ^ (z >> np.uint64(30))) * _MIX_1
            mixed = (mixed ^ (mixed >> np.uint64(27))) * _MIX_2
            mixed = mixed ^ (mixed >> np.uint64(31))
            out[row, column] = (np.float64(mixed >> np.uint64(11)) + 0.5) / 9007199254740992.0
    return out


def standard_normals(seed: int, keys: Sequence[ArrayLike], count: int) -> FloatArray:
    """Standard normal numbers fixed by ``seed`` and each row's keys (Box-Muller).

    Parameters
    ----------
    seed : int
    keys : sequence of array_like of int
        As :func:`uniforms`.
    count : int
        Numbers per row.

    Returns
    -------
    (M, count) array of float

    Raises
    ------
    ValueError
        As :func:`uniforms`.
    """
    pairs = (count + 1) // 2
    uniform = uniforms(seed, keys, 2 * pairs)
    # sqrt(-2 log u) cos(2 pi v) and its sin, each step in place: the same bits as
    # the expressions, with the swarm fit's (M, 192) draws held about three times, not six.
    radius = np.log(uniform[:, 0::2])
    radius *= -2.0
    np.sqrt(radius, out=radius)
    angle = np.multiply(uniform[:, 1::2], 2.0 * np.pi)
    del uniform
    normals = np.empty((len(radius), 2 * pairs), dtype=np.float64)
    np.cos(angle, out=normals[:, :pairs])
    np.sin(angle, out=normals[:, pairs:])
    normals[:, :pairs] *= radius
    normals[:, pairs:] *= radius
    return normals[:, :count] if count < 2 * pairs else normals
