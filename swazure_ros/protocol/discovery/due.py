"""Which labels an FLS sends in a round: those unsent whose bucket the round has reached.

A label is unsent while it is found, not sent and its source not closed. Its
bucket is its primary cost over the round's width, rounded down; it is due in
round k once its bucket is k or less and below the pass's reach. One rule for
an FLS picked alone (a row) and for a process's FLSs picked together (every
row), read in one compiled pass.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...core import jit
from ...core.arrays import FloatArray, IntArray
from .labels import LabelTable


def due_places(
    table: LabelTable, row: int | None, order: int, width: float, round_: float, reach: float
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray]:
    """The labels of row ``row`` of ``table`` (every row: None) due in round ``round_``.

    Parameters
    ----------
    table : LabelTable
    row : int or None
    order : int
        The policy's cost order (``labels.LENGTH_FIRST``, ...): its primary cost buckets.
    width, round_, reach : float
        Cost per round, the round (bucket), and the pass's reach in rounds.

    Returns
    -------
    rows, places : (L,) arrays of int
        The labels due, row by row, each row's by place.
    unsent : (F,) array of int
        Each row's unsent labels (F = 1 for one row).
    held_rows, held_places : (B,) arrays of int
        Every unsent label once ``round_`` is at the reach (held for the next
        pass); none before.
    """
    primary, found, sent, closed = table.due_inputs(row, order)
    # Floats, as the kernel is compiled for: a whole-number round would compile it again.
    rows, places, unsent, held_rows, held_places = _due_places(
        np.atleast_2d(primary), np.atleast_2d(found), np.atleast_2d(sent),
        np.atleast_2d(closed), float(width), float(round_), float(reach), round_ >= reach,
    )  # fmt: skip
    if row is not None:
        rows, held_rows = rows + row, held_rows + row
    return rows, places, unsent, held_rows, held_places


@jit.kernel(cache=True, nogil=True, parallel=True)
def _due_places(
    primary: FloatArray, found: NDArray[np.bool_], sent: NDArray[np.bool_],
    closed: NDArray[np.bool_], width: float, round_: float, reach: float, beyond: bool,
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray]:  # fmt: skip
    """:func:`due_places` of rows (F, R) in two passes, the rows shared among the cores;
    ``closed`` is (F, R), or (1, R) when every row shares it. numpy made eight (F, R)
    arrays a round for this."""
    rows_count, width_count = primary.shape
    shared = closed.shape[0] == 1
    unsent = np.zeros(rows_count, dtype=np.int64)
    due_count = np.zeros(rows_count, dtype=np.int64)
    for row in jit.prange(rows_count):
        # As an int64 of its own: numba unifies a prange index with 0 to a float.
        closed_row = np.int64(0) if shared else np.int64(row)
        row_unsent, row_due = 0, 0
        for place in range(width_count):
            if not found[row, place] or sent[row, place] or closed[closed_row, place]:
                continue
            row_unsent += 1
            bucket = np.floor(primary[row, place] / width)
            row_due += bucket <= round_ and bucket < reach
        unsent[row], due_count[row] = row_unsent, row_due
    # Each row writes its labels from its own start: the same order as one pass row by row.
    due_starts = np.zeros(rows_count + 1, dtype=np.int64)
    held_starts = np.zeros(rows_count + 1, dtype=np.int64)
    due_starts[1:] = np.cumsum(due_count)
    if beyond:
        held_starts[1:] = np.cumsum(unsent)
    due_rows, due_places = np.empty(due_starts[-1], np.int64), np.empty(due_starts[-1], np.int64)
    held_rows = np.empty(held_starts[-1], np.int64)
    held_places = np.empty(held_starts[-1], np.int64)
    for row in jit.prange(rows_count):
        due, held = due_starts[row], held_starts[row]
        closed_row = np.int64(0) if shared else np.int64(row)
        for place in range(width_count):
            if not found[row, place] or sent[row, place] or closed[closed_row, place]:
                continue
            bucket = np.floor(primary[row, place] / width)
            if bucket <= round_ and bucket < reach:
                due_rows[due], due_places[due] = row, place
                due += 1
            if beyond:
                held_rows[held], held_places[held] = row, place
                held += 1
    return due_rows, due_places, unsent, held_rows, held_places
