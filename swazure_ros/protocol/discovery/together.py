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

from ...core.arrays import IntArray
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
    unsent, due = table.due(None, first.order, first.width, bucket, first.reach)
    rows, places = np.nonzero(due)  # row by row
    if not table.direct:  # each row's labels by source: the order an FLS offers them in
        order = np.lexsort((table.keys[rows, places], rows))
        rows, places = rows[order], places[order]
    table.sent[rows, places] = True
    pending = np.bincount(rows, minlength=table.size) < unsent.sum(axis=1)
    beyond_rows = beyond_places = np.zeros(0, dtype=np.int64)
    if bucket >= first.reach:  # beyond the reach, every label below it sent (PathSearch.offer)
        beyond_rows, beyond_places = np.nonzero(unsent)
        pending[:] = False
    members = np.arange(table.size, dtype=np.int64)
    offers = offers_of(
        table, first.book, members, (rows, places), (beyond_rows, beyond_places), pending.tolist()
    )
    for one, offer in zip(searches, offers, strict=True):
        one._picked = (round_, offer)


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
