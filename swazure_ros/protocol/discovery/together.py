"""A process's FLSs stepped together: one compiled relaxation and one pick a round.

A packed process hosts hundreds or thousands of FLSs, each with its own
:class:`~.search.PathSearch`. Hearing a round's offers and picking the
labels due are the same work in every one of them, so the process does them
for all at once (:func:`hear_together`, :func:`pick_together`), over one
:class:`~.labels.LabelTable` whose rows are the FLSs' own labels. What each
FLS holds, offers and reports is what stepping it alone gives: its results,
paths and messages stay its own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...core import jit
from ...core.arrays import FloatArray, IntArray
from .heard import OffersHeard, offers_of
from .labels import LabelTable
from .messages import RoundOffers
from .search import PathSearch, heard_labels, take_changes


def _shared_table(searches: Sequence[PathSearch]) -> LabelTable | None:
    """The one table whose rows 0, 1, ... are ``searches``, made if need be (their
    records move to it); None when their runs differ."""
    runs = {
        (one.span, one.order, one.width, one.resumed, one.reach, one.table.id_space, one.fits)
        for one in searches
    }
    if len(runs) != 1:
        return None
    table = searches[0].table
    if table.size == len(searches) and all(
        one.table is table and one.row == row for row, one in enumerate(searches)
    ):
        return table
    table = LabelTable.merged([(one.table, one.row) for one in searches])
    # Each row's labels name the offers they came through by its old book's keys.
    book, bases = OffersHeard.merged([one.book for one in searches])
    table.via_offers += np.where(table.via_offers >= 0, bases[:, None], 0)
    for row, one in enumerate(searches):
        one.move_to(table, row, book)
    return table


def pick_together(searches: Sequence[PathSearch], round_: int, closed: IntArray) -> None:
    """Close the sources ``closed`` (ids) and pick the labels each of ``searches`` offers in
    round ``round_``, for all at once; :meth:`PathSearch.offer` then sends them.

    Searches that differ in their runs pick their own when they offer.
    """
    table = _shared_table(searches)
    if table is None:
        return
    first = searches[0]
    table.close(closed)
    bucket = first.resumed + round_
    # Beyond the reach, every label below it sent, the unsent are held (PathSearch.offer).
    beyond = bucket >= first.reach
    primary, found, sent, ended = table.due_inputs(None, first.order)
    rows, places, unsent, beyond_rows, beyond_places = _due_places(
        primary, found, sent, np.atleast_2d(ended), first.width, bucket, first.reach, beyond
    )
    if not table.direct:  # each row's labels by source: the order an FLS offers them in
        order = np.lexsort((table.keys[rows, places], rows))
        rows, places = rows[order], places[order]
    table.sent[rows, places] = True
    pending = np.bincount(rows, minlength=table.size) < unsent
    if beyond:
        pending[:] = False
    members = np.arange(table.size, dtype=np.int64)
    offers = offers_of(
        table, first.book, members, (rows, places), (beyond_rows, beyond_places), pending.tolist()
    )
    for one, offer in zip(searches, offers, strict=True):
        one._picked = (round_, offer)


@jit.kernel(cache=True, nogil=True)
def _due_places(
    primary: FloatArray, found: NDArray[np.bool_], sent: NDArray[np.bool_],
    closed: NDArray[np.bool_], width: float, round_: float, reach: float, beyond: bool,
) -> tuple[IntArray, IntArray, IntArray, IntArray, IntArray]:  # fmt: skip
    """:func:`.labels.labels_due` of every row (F, R) in two passes, as places: the rows and
    places of the labels due (row by row), each row's unsent labels (F,), and with
    ``beyond`` the rows and places of every unsent one. ``closed`` is (F, R), or (1, R)
    when every row shares it. numpy made eight (F, R) arrays a round for this."""
    rows_count, width_count = primary.shape
    shared = closed.shape[0] == 1
    unsent = np.zeros(rows_count, dtype=np.int64)
    due = 0
    for row in range(rows_count):
        for place in range(width_count):
            if not found[row, place] or sent[row, place] or closed[0 if shared else row, place]:
                continue
            unsent[row] += 1
            bucket = np.floor(primary[row, place] / width)
            due += bucket <= round_ and bucket < reach
    due_rows, due_places = np.empty(due, np.int64), np.empty(due, np.int64)
    held = unsent.sum() if beyond else 0
    held_rows, held_places = np.empty(held, np.int64), np.empty(held, np.int64)
    due, held = 0, 0
    for row in range(rows_count):
        for place in range(width_count):
            if not found[row, place] or sent[row, place] or closed[0 if shared else row, place]:
                continue
            bucket = np.floor(primary[row, place] / width)
            if bucket <= round_ and bucket < reach:
                due_rows[due], due_places[due] = row, place
                due += 1
            if beyond:
                held_rows[held], held_places[held] = row, place
                held += 1
    return due_rows, due_places, unsent, held_rows, held_places


def hear_together(searches: Sequence[PathSearch], heard: RoundOffers) -> None:
    """Every one of ``searches`` hears ``heard`` (:meth:`PathSearch.hear`), their labels
    relaxed in one compiled call: a process steps its FLSs together.

    The searches of one run and phase (one source span and policy) share one
    table from their first round heard together on; each keeps its own
    labels, results and paths, and ends as hearing alone would leave it.
    Searches that differ in their runs are heard one by one.
    """
    searches = [one for one in searches if one._last_heard is not heard]
    table = _shared_table(searches) if searches else None
    if table is None:
        for one in searches:
            one.hear(heard)
        return
    for one in searches:
        one._hear_first(heard)
    rows = np.arange(len(searches), dtype=np.int64)
    first = searches[0]
    starts, changes = table.relax(rows, first.order, heard_labels(heard))
    take_changes(table, first.book, first.fit, heard, rows, starts, changes)
