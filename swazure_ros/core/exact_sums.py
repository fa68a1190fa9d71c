"""Sums over the swarm, exact: each column's ``math.fsum``, compiled.

The swarm's conjugate gradients (:mod:`.conjugate_gradients`) sum every FLS's
shares of two dot products each iteration. Exact sums, rounded once, are the
same in any order, so the processes of a swarm adding their own FLSs' shares
and the engine adding every FLS's get the same bits. The compiled sum adds
each share to a long fixed-point accumulator (Kulisch's); CPython's
``math.fsum`` answers the sums the compiled one leaves (non-finite shares,
shares of 2^960 or more) and every sum of a process that runs its kernels as
Python.
"""

from __future__ import annotations

import math

import numpy as np

from . import jit
from .arrays import FloatArray, IntArray


def swarm_sum(partials: FloatArray) -> FloatArray:
    """The sums over the swarm of every FLS's shares: exact, so in any order.

    ``math.fsum``, correctly rounded: a process's exact sum, rounded once,
    is what the engine gets over every FLS at once.

    Parameters
    ----------
    partials : (N, K) array of float

    Returns
    -------
    (K,) array of float

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.exact_sums import swarm_sum
    >>> swarm_sum(np.array([[1e16, 1.0], [1.0, 2.0], [-1e16, 3.0]]))  # no 1.0 lost
    array([1., 6.])
    """
    shares = np.ascontiguousarray(partials, dtype=np.float64)
    if not jit.INTERPRET:
        # inf and NaN have the largest exponent: the compiled sum leaves them too.
        sums = _exact_sums(shares.view(np.int64), _CARRY_EVERY)
        if np.isfinite(sums).all():
            return sums
    # Interpreted, or at the edges (inf, NaN, a share too large for the compiled sum):
    # CPython's own.
    return np.array([math.fsum(column) for column in shares.T.tolist()], dtype=np.float64)


#: Bits of each place of the compiled sum's fixed-point accumulator. A double is an integer
#: of 53 bits times 2^(s - 1074), 0 <= s <= 2045, so it falls on at most three places.
_PLACE_BITS = 32
_PLACE_MASK = (1 << _PLACE_BITS) - 1
#: Places from 2^-1074 up, with room for the carries of a sum below 2^1023.
_PLACES = 2046 // _PLACE_BITS + 4
#: Shares of 2^960 or more (this biased exponent and up) are left to CPython, whose
#: partials can overflow on the way where the exact sum does not; below it they cannot.
_HUGE_EXPONENT = 1023 + 960
#: Shares added between carries: each adds under 2^32 to a place of 63 bits.
_CARRY_EVERY = 1 << 30
#: Room for partials the final rounding starts with; it grows if need be.
_PARTIALS = 2 * _PLACES


@jit.kernel(cache=True)
def _exact_sums(bits: IntArray, carry_every: int) -> FloatArray:  # pragma: no cover - compiled
    """``math.fsum`` of each column of ``bits`` (N, K), doubles seen as int64, compiled.

    Each share's integer is added exactly, in pieces of :data:`_PLACE_BITS`, to
    its column's fixed-point accumulator spanning every double (Kulisch's long
    accumulator); its places, carried and each an exact double, are then
    summed as CPython's fsum sums (Shewchuk's non-overlapping partials, then
    its half-even rounding). The exact sum rounded once is what fsum
    returns, to the bit, in a fraction of its time (BENCHMARKS.md). A column
    with a share of 2^960 or more, inf or NaN is NaN: the caller hands it to CPython.
    """
    count = bits.shape[1]
    places = np.zeros((count, _PLACES), dtype=np.int64)
    huge = np.zeros(count, dtype=np.bool_)
    until_carry = carry_every
    for row in range(bits.shape[0]):
        for column in range(count):
            word = bits[row, column]
            biased = (word >> 52) & 0x7FF
            if biased >= _HUGE_EXPONENT:
                huge[column] = True
                continue
            mantissa = word & ((1 << 52) - 1)
            shift = 0
            if biased > 0:
                mantissa |= 1 << 52
                shift = biased - 1
            place = shift >> 5
            offset = shift & 31
            low = (mantissa & ((1 << (_PLACE_BITS - offset)) - 1)) << offset
            rest = mantissa >> (_PLACE_BITS - offset)
            if word < 0:
                low, rest = -low, -rest
            # rest's pieces, as the shift rounds down, sum to rest whatever its sign.
            places[column, place] += low
            places[column, place + 1] += rest & _PLACE_MASK
            places[column, place + 2] += rest >> _PLACE_BITS
        until_carry -= 1
        if until_carry == 0:
            until_carry = carry_every
            for column in range(count):
                _carried(places[column])
    out = np.empty(count)
    partials = np.empty(_PARTIALS)
    for column in range(count):
        out[column] = np.nan if huge[column] else _rounded_places(places[column], partials)
    return out


@jit.kernel(cache=True)
def _rounded_places(places: IntArray, partials: FloatArray) -> float:  # pragma: no cover
    """The accumulator's exact sum rounded once, as CPython's fsum rounds; ``places``
    is used up, ``partials`` is room."""
    _carried(places)
    # A negative sum is summed as its magnitude: carried, its places are then all in
    # [0, 2^32), each an exact double with no borrow from the top worth 2^1038.
    sign = 1.0
    if places[-1] < 0:
        sign = -1.0
        places[:] = -places
        _carried(places)
    used = 0
    for place in range(len(places)):
        if places[place] != 0:
            value = math.ldexp(float(places[place]), _PLACE_BITS * place - 1074)
            partials, used = _with_partial(partials, used, value)
    return sign * _rounded(partials, used)


@jit.kernel(cache=True)
def _carried(places: IntArray) -> None:  # pragma: no cover - compiled
    """Carry each place of the accumulator into the next, leaving each in [0, 2^32) but the
    last, which keeps the sign."""
    for place in range(len(places) - 1):
        carry = places[place] >> _PLACE_BITS
        places[place] -= carry << _PLACE_BITS
        places[place + 1] += carry


@jit.kernel(cache=True)
def _with_partial(
    partials: FloatArray, used: int, value: float
) -> tuple[FloatArray, int]:  # pragma: no cover - compiled
    """``value`` added to the non-overlapping ``partials[:used]``: CPython's fsum's step."""
    x = value
    kept = 0
    for place in range(used):
        y = partials[place]
        if abs(x) < abs(y):
            x, y = y, x
        high = x + y
        low = y - (high - x)
        if low != 0.0:
            partials[kept] = low
            kept += 1
        x = high
    if x != 0.0:
        if kept == len(partials):
            partials = np.concatenate((partials, np.empty(len(partials))))
        partials[kept] = x
        kept += 1
    return partials, kept


@jit.kernel(cache=True)
def _rounded(partials: FloatArray, used: int) -> float:  # pragma: no cover - compiled
    """The sum of ``partials[:used]``, rounded once, half to even: CPython's fsum's ending."""
    high = 0.0
    count = used
    if count == 0:
        return high
    count -= 1
    high = partials[count]
    low = 0.0
    while count > 0:
        x = high
        count -= 1
        y = partials[count]
        high = x + y
        low = y - (high - x)
        if low != 0.0:
            break
    if count > 0 and (
        (low < 0.0 and partials[count - 1] < 0.0) or (low > 0.0 and partials[count - 1] > 0.0)
    ):
        y = low * 2.0
        x = high + y
        if y == x - high:
            high = x
    return float(high)
