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

import operator
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...core import jit
from ...core.arrays import IntArray
from .due import due_places
from .heard import OffersHeard, offers_of
from .labels import Changes, Columns, HeardLabels, LabelTable, candidates, relax_rows
from .links import Links
from .messages import RoundOffers, sender_rows
from .search import PathSearch, hear_first, heard_labels, table_for, take_changes

#: What searches that share a table have alike (a process's thousands are read in C).
_RUN = operator.attrgetter("span", "order", "width", "resumed", "reach", "id_space", "fits")


def _shared_table(searches: Sequence[PathSearch]) -> LabelTable | None:
    """The one table whose rows 0, 1, ... are ``searches``, made if need be (fresh searches
    start in it, the others' records move to it); None when their runs differ."""
    if len(set(map(_RUN, searches))) != 1:
        return None
    if all(one.fresh for one in searches):  # a process's FLSs that start a phase together
        return table_for(searches)
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


def close_together(searches: Sequence[PathSearch], closed: IntArray) -> None:
    """Close the sources ``closed`` (ids) in every one of ``searches``, each table once:
    before a round is heard, so that no label of a finished source is relaxed."""
    shared = _shared_table(searches) if searches else None
    tables = [shared] if shared is not None else [one.table for one in searches]
    for table in {id(table): table for table in tables}.values():
        table.close(closed)


def pick_together(searches: Sequence[PathSearch], round_: int, closed: IntArray) -> bool:
    """Close the sources ``closed`` (ids) and pick the labels each of ``searches`` offers in
    round ``round_``, for all at once; :meth:`PathSearch.offer` then sends them.

    Returns False, picking nothing, when the searches differ in their runs:
    each then picks its own when it offers.
    """
    table = _shared_table(searches)
    if table is None:
        return False
    first = searches[0]
    table.close(closed)
    bucket = first.resumed + round_
    rows, places, unsent, beyond_rows, beyond_places = due_places(
        table, None, first.order, first.width, bucket, first.reach
    )
    if not table.direct:  # each row's labels by source: the order an FLS offers them in
        order = np.lexsort((table.keys[rows, places], rows))
        rows, places = rows[order], places[order]
    table.sent[rows, places] = True
    # Beyond the reach, every label below it sent, the unsent are held, none pending.
    pending = (np.bincount(rows, minlength=table.size) < unsent) & (bucket < first.reach)
    members = np.arange(table.size, dtype=np.int64)
    offers = offers_of(
        table, first.book, members, (rows, places), (beyond_rows, beyond_places), pending.tolist()
    )
    for one, offer in zip(searches, offers, strict=True):
        one._picked = (round_, offer)
    return True


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
    hear_first(searches, heard)
    if not len(heard.source_ids):  # no label to relax: their hops need not be made
        return
    rows = np.arange(len(searches), dtype=np.int64)
    first = searches[0]
    starts, changes = relax_together(table, rows, first.order, heard_labels(heard))
    take_changes(table, first.book, first.fit, heard, rows, starts, changes)


#: Rows from which a direct table's relaxation is shared among the cores.
PARALLEL_ROWS = 64
#: The most changes one wave of a shared relaxation has room for (three int64 each).
_WAVE = 1 << 22


def relax_together(
    table: LabelTable, rows: IntArray, order: int, heard: HeardLabels
) -> tuple[IntArray, Changes]:
    """``table.relax(rows, order, heard)``, the rows of a direct table shared among the cores.

    Each row's labels are its own, so each core relaxes a share of the rows
    (:func:`.labels.relax_rows`, in :func:`_relax_chunks`) with room for the
    most changes its rows can take (a place each), and the changes come back
    row by row: what one call gives. Rows go in waves of :data:`_WAVE` changes
    at most, so the room stays bounded. A hashed table (its rows widen as
    they go) and a few rows are relaxed in one call. The labels of closed
    sources are dropped first (:func:`open_labels`).
    """
    heard, kept = open_labels(heard, table.closed)
    starts, changes = _relax_open(table, rows, order, heard)
    if kept is not None:  # each change names its label in the labels heard
        changes = changes._replace(labels=kept[changes.labels])
    return starts, changes


def open_labels(
    heard: HeardLabels, closed: NDArray[np.bool_]
) -> tuple[HeardLabels, IntArray | None]:
    """``heard`` without the labels of the ``closed`` sources (by id; empty: none), and
    where each label kept is in ``heard`` (None: all are kept, ``heard`` itself).

    The relaxation skips a closed source's label anyway, but it reads it once for
    each row that hears its sender (hundreds on the published shapes): dropped
    here, it is read once.
    """
    ids = heard.source_ids
    if not len(closed) or not len(ids):
        return heard, None
    known = (ids >= 0) & (ids < len(closed))
    shut = np.zeros(len(ids), dtype=bool)
    shut[known] = closed[ids[known]]
    if not shut.any():
        return heard, None
    kept = np.flatnonzero(~shut)
    before = np.zeros(len(ids) + 1, dtype=np.int64)
    np.cumsum(~shut, out=before[1:])
    _, _, source_ids, hops, lengths, errors = heard
    return HeardLabels(
        heard.senders,
        before[heard.starts],
        source_ids[kept],
        hops[kept],
        lengths[kept],
        errors[kept],
    ), kept


def _relax_open(
    table: LabelTable, rows: IntArray, order: int, heard: HeardLabels
) -> tuple[IntArray, Changes]:
    """:func:`relax_together` of labels ``heard`` of open sources."""
    if not table.direct or len(rows) < PARALLEL_ROWS:
        return table.relax(rows, order, heard)
    chunks = 2 * jit.get_num_threads()
    room = _rooms(
        rows, table.link_starts, table.links.ids, heard.senders, heard.starts, table.width
    )
    ends = np.cumsum(room)
    starts, parts, begin, before = [np.zeros(1, dtype=np.int64)], [], 0, 0
    while begin < len(rows):
        end = max(
            begin + 1, int(np.searchsorted(ends, ends[begin] - room[begin] + _WAVE, "right"))
        )
        wave_starts, wave = _relax_wave(
            table, rows[begin:end], room[begin:end], order, heard, chunks
        )
        starts.append(wave_starts[1:] + before)
        parts.append(wave)
        begin, before = end, before + int(wave_starts[-1])
    return np.concatenate(starts), Changes(*(np.concatenate(one) for one in zip(*parts)))


def _relax_wave(
    table: LabelTable, rows: IntArray, room: IntArray, order: int, heard: HeardLabels, chunks: int
) -> tuple[IntArray, Changes]:
    """:func:`relax_together` of ``rows`` (their ``room``) in ``chunks`` shares at once."""
    ends = np.cumsum(room)
    cuts = np.searchsorted(ends, np.linspace(0, ends[-1], chunks + 1)[1:-1], "right")
    row_bounds = np.concatenate([[0], cuts, [len(rows)]]).astype(np.int64)
    room_bounds = np.concatenate([[0], ends])[row_bounds].astype(np.int64)
    buffers = Changes(*(np.empty(int(room_bounds[-1]), dtype=np.int64) for _ in range(3)))
    change_starts = np.zeros(len(rows) + chunks, dtype=np.int64)
    won = np.full((2, chunks, table.width), -1, dtype=np.int64)
    filled = np.zeros(chunks, dtype=np.int64)
    _relax_chunks(
        row_bounds, room_bounds, rows, table.mes, order, table.span_array, table.run_ids,
        table.slots, table.link_starts, table.links, heard, table.closed, table.columns(),
        buffers, change_starts, won, filled,
    )  # fmt: skip
    starts, parts, before = [np.zeros(1, dtype=np.int64)], [], 0
    for chunk in range(chunks):
        low, high = row_bounds[chunk], row_bounds[chunk + 1]
        starts.append(change_starts[low + chunk + 1 : high + chunk + 1] + before)
        at = slice(room_bounds[chunk], room_bounds[chunk] + filled[chunk])
        parts.append(Changes(*(one[at] for one in buffers)))
        before += int(filled[chunk])
    return np.concatenate(starts), Changes(*(np.concatenate(one) for one in zip(*parts)))


@jit.kernel(cache=True, nogil=True)
def _rooms(
    rows: IntArray, link_starts: IntArray, link_ids: IntArray, senders: IntArray,
    starts: IntArray, width: int,
) -> IntArray:  # fmt: skip
    """The most changes each of ``rows`` of a direct table (``width`` places) can take."""
    room = np.empty(len(rows), dtype=np.int64)
    for at in range(len(rows)):
        low, high = link_starts[rows[at]], link_starts[rows[at] + 1]
        room[at] = candidates(sender_rows(link_ids[low:high], senders), starts, width)
    return room


@jit.kernel(cache=True, nogil=True, parallel=True)
def _relax_chunks(
    row_bounds: IntArray, room_bounds: IntArray, rows: IntArray, mes: IntArray, order: int,
    span: IntArray, run_ids: IntArray | None, slots: NDArray[np.int32] | None,
    link_starts: IntArray, links: Links, heard: HeardLabels, closed: NDArray[np.bool_],
    columns: Columns, buffers: Changes, change_starts: IntArray, won: IntArray,
    filled: IntArray,
) -> None:  # fmt: skip
    """:func:`.labels.relax_rows` of each share of ``rows`` (``row_bounds``) on a core of its
    own, into its room of ``buffers`` (``room_bounds``, enough for every change); share k's
    rows' change offsets go to ``change_starts[row_bounds[k] + k:]``, its count to
    ``filled[k]``; ``won`` (2, K, R) is each share's record of the row in hand."""
    for chunk in jit.prange(len(row_bounds) - 1):
        low, high = row_bounds[chunk], row_bounds[chunk + 1]
        first, end = room_bounds[chunk], room_bounds[chunk + 1]
        mine = Changes(
            buffers.places[first:end], buffers.labels[first:end], buffers.links[first:end]
        )
        record = Changes(buffers.places[:0], won[0, chunk], won[1, chunk])
        resume = np.full(2, -1, dtype=np.int64)
        _, filled[chunk], _ = relax_rows(
            rows[low:high],
            0,
            mes,
            order,
            span,
            run_ids,
            slots,
            link_starts,
            links,
            heard,
            closed,
            columns,
            mine,
            0,
            change_starts[low + chunk : high + chunk + 1],
            record,
            resume,
        )
