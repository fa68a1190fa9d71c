"""The decaying pairs' line of sight as regions judged it, each pair's kept once (numba kernels).

:mod:`.local_paths` searches decaying paths region by region, and regions
overlap; line of sight is most of a region's work. A pair's sight is the
whole swarm's (every FLS may block it), so one record serves every region:
:class:`JudgedSight` judges the pairs no region judged before and reads
the others back.
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

from . import jit
from .arrays import BoolArray, IntArray
from .fans import obstructed_fans
from .geometry import Swarm
from .grid import Grid

#: An empty place of the hash (a pair's key halved is never -1).
NO_PAIR = -1
#: Fibonacci hashing's multiplier (2**64 over the golden ratio, odd): the keys of one
#: FLS's pairs, consecutive, spread over the table.
_FIBONACCI = np.uint64(0x9E3779B97F4A7C15)


class JudgedSight:
    """Decaying pairs' line of sight, each pair's judged and kept once, for many regions.

    An open-addressing hash of the pairs' keys (``first * N + second``), twice
    over with their sight as the lowest bit, at most three quarters full (11 to
    21 bytes a pair). Regions searched on two threads may ask at once: the
    hash is read and written by one at a time, and pairs are judged outside
    that lock, so a pair two regions ask for before either has entered it is
    judged by both and entered once (``judged`` counts it once).

    Parameters
    ----------
    size : int
        N, the swarm's FLSs.
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self.table = np.full(1024, NO_PAIR, dtype=np.int64)
        self.judged = 0  # pairs entered so far, each once
        self._lock = threading.Lock()

    def of(self, swarm: Swarm, grid: Grid, first: IntArray, second: IntArray) -> BoolArray:
        """Whether each decaying pair first[m]-second[m] is in sight, judging those not
        entered before.

        Parameters
        ----------
        swarm : Swarm
            The whole swarm: every FLS may block a pair.
        grid : Grid
            The swarm's line-of-sight grid (:func:`.grid.build_grid`), built once for
            every region.
        first, second : (M,) ndarray of int
            The pairs, FLS indices.

        Returns
        -------
        (M,) ndarray of bool
            In sight, as :func:`.fans.obstructed_fans` judges it.
        """
        state = np.empty(len(first), dtype=np.int8)
        with self._lock:
            _read_back(self.table, _shift(self.table), self.size, first, second, state)
        visible = state > 0
        new = np.flatnonzero(state < 0)
        visible[new] = ~obstructed_fans(
            swarm.points, swarm.radius, first[new], second[new], grid=grid
        )
        values = 2 * (first[new] * self.size + second[new]) + visible[new]
        with self._lock:
            self._make_room(len(new))
            self.judged += int(_enter(self.table, _shift(self.table), values))
        return visible

    def _make_room(self, more: int) -> None:
        """Widen the hash, twice over as often as needed, for ``more`` pairs."""
        size = len(self.table)
        while 4 * (self.judged + more) > 3 * size:
            size *= 2
        if size > len(self.table):
            wider = np.full(size, NO_PAIR, dtype=np.int64)
            _enter(wider, _shift(wider), self.table[self.table != NO_PAIR])
            self.table = wider


def _shift(table: IntArray) -> int:
    """What a hash's product is shifted right by to place a key in ``table`` (2**k long)."""
    return 64 - (len(table).bit_length() - 1)


@jit.kernel(cache=True, nogil=True)
def _home(table: IntArray, shift: int, key: int) -> np.int64:
    """Where a pair's ``key`` is in ``table``, or the empty place it goes: its hash's
    place, then the next ones."""
    # In uint64 throughout: numba's int64 and uint64 make a float64.
    at = (np.uint64(key) * _FIBONACCI) >> np.uint64(shift)
    mask = np.uint64(len(table) - 1)
    while table[at] != NO_PAIR and table[at] >> 1 != key:
        at = (at + np.uint64(1)) & mask
    return np.int64(at)


@jit.kernel(cache=True, nogil=True)
def _enter(table: IntArray, shift: int, values: IntArray) -> int:
    """Enter ``values`` (a pair's key twice over plus its sight) in ``table``; return how
    many were not there."""
    entered = 0
    for value in values:
        at = _home(table, shift, value >> 1)
        if table[at] == NO_PAIR:
            entered += 1
            table[at] = value
    return entered


@jit.kernel(cache=True, parallel=True)
def _read_back(
    table: IntArray,
    shift: int,
    size: int,
    first: IntArray,
    second: IntArray,
    state: NDArray[np.int8],
) -> None:
    """Each pair's sight as entered: ``state`` 1 in sight, 0 not, -1 not entered yet."""
    for m in jit.prange(len(first)):
        value = table[_home(table, shift, first[m] * size + second[m])]
        state[m] = -1 if value == NO_PAIR else value & 1
