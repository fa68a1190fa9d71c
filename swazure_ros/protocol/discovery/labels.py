"""The labels of one phase of a discovery run: one place per FLS and source that reached it.

An FLS keeps a label only for a source whose search has reached it (heard
from a neighbour it relays from), so its memory and its work each round
grow with the searches that pass through it, not with the swarm: a source's
search reaches the FLSs within a few sweet hops of it, however many FLSs
fly (issue 67). A :class:`LabelTable` holds the labels of one FLS (a search
stepped alone) or of every FLS a process steps together: row f of its
(F, R) arrays is FLS f's, a row's R places an open-addressing hash of
source ids, each FLS's labels side by side in memory as the relaxation
reads them. R grows as a row fills; once it would reach the run's number of
sources, a source's place is simply its slot: its rank among the run's
sources (source - first when they are every id of their span), the layout
of a swarm whose every search reaches every FLS (the published shapes).

The relaxation (:func:`LabelTable.relax`) is the same compiled pass for one
row and for thousands: each candidate (a heard label plus the hop from its
sender) replaces its source's label when it is better under the total order
(primary cost, secondary cost, sender id).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ...core import jit
from ...core.arrays import FloatArray, IntArray
from .links import Links, RowHops, RowsLinks, joined_links
from .messages import sender_rows
from .places import EMPTY, place_bytes, slot_map, slot_of, table_columns

#: The order of a label's costs in each policy: (primary, secondary), as the relaxation reads them.
HOPS_FIRST, LENGTH_FIRST, ERROR_FIRST = 0, 1, 2

#: Source ids are below 2**32, so an id times this odd constant stays below 2**62:
#: no overflow, compiled or interpreted (the ``fls`` program runs kernels as Python).
_MIX = 0x2545F491


class HeardLabels(NamedTuple):
    """The labels of a :class:`~.messages.RoundOffers`, L in all, grouped by sender."""

    senders: IntArray  # (S,) sorted sender ids
    starts: IntArray  # (S + 1,) sender k's labels are starts[k]:starts[k + 1]
    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    errors: FloatArray  # (L,)


class Columns(NamedTuple):
    """What the relaxation reads and writes of a :class:`LabelTable`: one kernel argument."""

    keys: IntArray  # (F, R) the source of each place, -1 where empty
    sent: NDArray[np.bool_]  # (F, R)
    hops: FloatArray  # (F, R)
    length: FloatArray  # (F, R), cm
    error: FloatArray  # (F, R)
    pred: IntArray  # (F, R), the sender of each label
    occupied: IntArray  # (F,) places taken in each row (kept while the rows hash)


class Changes(NamedTuple):
    """Labels bettered in one relaxation, row by row: one kernel argument."""

    places: IntArray  # (M,) each in its row
    labels: IntArray  # (M,) the heard label that won each
    links: IntArray  # (M,) and the link it came by, an index into its FLS's links


@jit.kernel(cache=True, nogil=True)
def _place(keys: IntArray, source: int) -> int:
    """The place of ``source`` in a hashed row whose sources are ``keys`` (R,): where it
    is, or the empty place it goes (a direct row's place is its slot, source - first)."""
    mask = len(keys) - 1
    at = ((source * _MIX) >> 15) & mask
    while keys[at] != EMPTY and keys[at] != source:
        at = (at + 1) & mask
    return at


@jit.kernel(cache=True, nogil=True)
def _insert(
    keys: IntArray,
    rows: IntArray,
    sources: IntArray,
    first: int,
    direct: bool,
    run_ids: IntArray | None,
) -> IntArray:
    """Put ``sources`` (M,) in rows ``rows`` (M,) of ``keys`` (F, R); their places."""
    places = np.empty(len(rows), dtype=np.int64)
    for k in range(len(rows)):
        if direct:  # the slot; a direct table keeps no keys
            places[k] = slot_of(run_ids, first, sources[k])
            continue
        place = _place(keys[rows[k]], sources[k])
        keys[rows[k], place] = sources[k]
        places[k] = place
    return places


@jit.kernel(cache=True, nogil=True)
def relax_rows(
    rows: IntArray, begin: int, mes: IntArray, order: int, span: IntArray,
    run_ids: IntArray | None, slots: NDArray[np.int32] | None, link_starts: IntArray,
    links: Links, heard: HeardLabels, closed: NDArray[np.bool_], columns: Columns,
    changes: Changes, filled: int, change_starts: IntArray, won: Changes, resume: IntArray,
) -> tuple[int, int, int]:  # fmt: skip
    """Relax the labels of table rows ``rows[begin:]`` (FLS ``mes[row]``, its links
    ``link_starts[row]:link_starts[row + 1]``) through the labels ``heard``.

    ``span`` is (first, end): sources outside first..end - 1 are not this run's, nor,
    when ``run_ids`` (sorted; None: all) names its sources, ids it names not: a direct
    table's ``slots`` (:func:`.places.slot_map`, None when ``run_ids`` is) give their
    places. ``closed`` (id_space,) marks the sources whose search ended (empty: none),
    neither kept nor relaxed. A source first heard takes an empty place. Row
    ``rows[k]``'s bettered places go to ``changes[change_starts[k]:change_starts[k + 1]]``,
    from ``filled`` on.
    ``won`` (R,) are the winning label and link of each place of the row in hand, -1
    where it has not changed (as the call leaves them).

    Returns (next, filled, need): ``next`` is ``len(rows)`` when every row is done. Else
    row ``rows[next]`` stopped: with ``need`` 0 before it began, for more room in
    ``changes``; else before its hash would be over half full, to go on at ``resume``
    (link, label) once its places are ``need`` at most half full, ``won`` and its
    changes so far moved to their new places.
    """
    first, end, has_closed = span[0], span[1], len(closed) > 0
    link_ids, link_weights, link_errors = links.ids, links.weights, links.errors
    senders, starts, source_ids, label_hops, label_lengths, label_errors = heard
    keys, sent, hops, length, error, pred, occupied = columns
    width, direct = hops.shape[1], keys.shape[1] == 0  # a direct table keeps no keys
    for at in range(begin, len(rows)):
        row, low, high = rows[at], link_starts[rows[at]], link_starts[rows[at] + 1]
        found = sender_rows(link_ids[low:high], senders)
        resumed = at == begin and resume[0] >= 0
        first_link, first_label = (resume[0], resume[1]) if resumed else (0, -1)
        room = candidates(found, starts, width if direct else -1)
        if not resumed and filled + room > len(changes.places):
            return at, filled, 0
        resume[0], resume[1] = -1, -1
        me, row_keys, row_sent, row_pred = mes[row], keys[row], sent[row], pred[row]  # its own
        row_hops, row_length, row_error = hops[row], length[row], error[row]
        for k in range(first_link, high - low):
            if found[k] < 0:
                continue
            sender = link_ids[low + k]
            weight, link_error = link_weights[low + k], link_errors[low + k]
            label_from = first_label if k == first_link and first_label >= 0 else starts[found[k]]
            for label in range(label_from, starts[found[k] + 1]):
                source = source_ids[label]
                if source < first or source >= end or source == me:  # not this run's, or its own
                    continue
                # A slot per source is looked up, inline (a call a candidate cost 4x the pass,
                # a search 15x); a hash, of a few labels a row, searches the run's sources.
                if slots is not None:
                    rank = int(slots[source - first])
                else:
                    rank = source - first if run_ids is None else slot_of(run_ids, first, source)
                if rank < 0 or (has_closed and closed[source]):  # not a spread run's, or ended
                    continue
                place = rank if direct else _place(row_keys, source)
                if not direct and row_keys[place] == EMPTY:
                    if 2 * (occupied[row] + 1) > width:
                        resume[0], resume[1] = k, label
                        return at, filled, occupied[row] + 1
                    row_keys[place] = source  # its costs are the empty place's: none yet
                    occupied[row] += 1
                # Sums in path order, as the engine sums them: cost so far plus this hop.
                # The first key alone rejects nearly every candidate, sent labels among
                # them (final, so never bettered): read before the rest, and before
                # `sent`, whose branch the processor cannot guess (the pass took 1.7x).
                if order == LENGTH_FIRST:
                    new1, old1 = label_lengths[label] + weight, row_length[place]
                elif order == HOPS_FIRST:
                    new1, old1 = label_hops[label] + 1.0, row_hops[place]
                else:
                    new1, old1 = label_errors[label] + link_error, row_error[place]
                if new1 > old1 or row_sent[place]:
                    continue
                new_hops = label_hops[label] + 1.0
                new_length = label_lengths[label] + weight
                new_error = label_errors[label] + link_error
                old_hops, old_length = row_hops[place], row_length[place]
                if order == HOPS_FIRST:
                    new2, old2 = new_length, old_length
                else:
                    new2, old2 = new_hops, old_hops
                if new1 < old1 or (
                    new1 == old1 and (new2 < old2 or (new2 == old2 and sender < row_pred[place]))
                ):
                    if won.labels[place] < 0:
                        changes.places[filled] = place
                        filled += 1
                    row_hops[place], row_length[place] = new_hops, new_length
                    row_error[place], row_pred[place] = new_error, sender
                    won.labels[place], won.links[place] = label, k
        _take_winners(changes, change_starts[at], filled, won)
        change_starts[at + 1] = filled
    return len(rows), filled, 0


@jit.kernel(cache=True, nogil=True)
def candidates(found: IntArray, starts: IntArray, most: int) -> int:
    """The labels the senders at rows ``found`` (-1: none) of ``starts`` offer, or ``most``
    if fewer (-1: no bound): a direct row's changes, a place each at most."""
    count = 0
    for row in found:
        if row >= 0:
            count += starts[row + 1] - starts[row]
    return count if most < 0 else min(count, most)


@jit.kernel(cache=True, nogil=True)
def _take_winners(changes: Changes, begin: int, end: int, won: Changes) -> None:
    """Give ``changes[begin:end]`` (one row's) their winning labels and links from
    ``won``, which is left with none for the next row."""
    for change in range(begin, end):
        place = changes.places[change]
        changes.labels[change], changes.links[change] = won.labels[place], won.links[place]
        won.labels[place] = -1


class LabelTable:
    """The labels of F FLSs (rows) in one phase of one run, a place per source heard.

    ``mes`` (F,) are the FLSs' ids, ``link_starts`` (F + 1,) and ``links``
    their hops relayed from, or ``row_hops`` that make them when the table first needs
    them: a relay that hears no offer in a phase never holds its hops (in a
    display's SD_vis phase, tens of millions per process); ``span`` (first, end)
    the run's sources (``sources``, sorted, when they are not every id of it) and
    ``id_space`` a bound on ids; ``fits``: labels also sum unbiased hops and
    their covariances (``unbiased``, ``covariance``). Each column
    (``keys``, the source of each place, none in a direct table, ``sent``, ``hops``, ``length``,
    ``error``, ``pred``, ``via_offers``, ``via_label``, ``via_link``) is (F, R, ...). A
    label's path and vector are read from the offers and the link it won through
    (:meth:`.heard.OffersHeard.paths`, :meth:`~.heard.OffersHeard.add_vectors`).
    """

    # The columns, (F, R, ...) each: made by _allocate, as .places.table_columns lists them.
    keys: IntArray
    sent: NDArray[np.bool_]
    hops: FloatArray
    length: FloatArray
    error: FloatArray
    pred: IntArray
    via_offers: IntArray
    via_label: IntArray
    via_link: IntArray
    unbiased: FloatArray
    covariance: FloatArray

    def __init__(
        self,
        mes: IntArray,
        link_starts: IntArray | None,
        links: Links | None,
        span: tuple[int, int],
        id_space: int,
        fits: bool,
        need: int = 1,
        sources: IntArray | None = None,
        row_hops: Sequence[RowHops] | None = None,
    ) -> None:
        self.mes = np.asarray(mes, dtype=np.int64)
        self.rows_links = RowsLinks(link_starts, links, row_hops)
        self.span, self.id_space, self.fits = span, id_space, fits
        self.span_array = np.array(span, dtype=np.int64)
        # The run's sources by slot; None when they are every id of the span (slot: id -
        # first): numba then compiles the relaxation without their search (31 s, not 36-39).
        spread = sources is not None and len(sources) < span[1] - span[0]
        # Contiguous: a strided array is a type of its own to the kernels (compiled again).
        self.run_ids: IntArray | None = (
            np.ascontiguousarray(sources, dtype=np.int64)
            if sources is not None and spread
            else None
        )
        self._slots: NDArray[np.int32] | None = None  # slot_map(run_ids), once relaxed
        self.closed = np.zeros(0, dtype=bool)  # (id_space,) once a source is closed
        self._last_closed: object = None  # the ids :meth:`close` took last, as given
        self._changes_last = 0
        self.occupied = np.zeros(len(self.mes), dtype=np.int64)
        self.direct, width = self._width_for(need)
        self._allocate(width)

    @property
    def link_starts(self) -> IntArray:
        """(F + 1,) where each row's links start in :attr:`links` (made if need be)."""
        return self.rows_links.starts

    @property
    def links(self) -> Links:
        """The hops the rows relay from (made if need be: :class:`.links.RowsLinks`)."""
        return self.rows_links.links

    def _width_for(self, need: int) -> tuple[bool, int]:
        """(direct, R) for rows of ``need`` labels: a hash at most half full, or a slot per
        source once such a hash would be half as wide as the slots or more."""
        sources = self.span[1] - self.span[0] if self.run_ids is None else len(self.run_ids)
        width = 1 << max(3, int(2 * need - 1).bit_length())
        # A hash half the slots' size saves too little for its probes and its moves.
        return (True, sources) if 2 * width >= sources else (False, width)

    def _allocate(self, width: int) -> None:
        for name, (empty, shape, dtype) in table_columns(self.fits).items():
            # A direct table's places are its sources' slots: it keeps no keys.
            wide = 0 if name == "keys" and self.direct else width
            setattr(self, name, np.full((len(self.mes), wide, *shape), empty, dtype=dtype))
        # Read by every offer (Offer.label_bytes): worked out once per layout.
        self._row_bytes = width * place_bytes(self.direct, self.fits)

    @property
    def slots(self) -> NDArray[np.int32] | None:
        """A direct table's slot for each id of a spread run's span (:func:`.places.slot_map`),
        made when first needed; None for a hash, which searches the run's sources, and
        where every id of the span is a source. A table that never relaxes (a packed FLS's
        own, before its process steps it with others) holds none."""
        if self.direct and self.run_ids is not None and self._slots is None:
            self._slots = slot_map(self.run_ids, self.span)
        return self._slots

    @property
    def size(self) -> int:
        """How many FLSs (rows) it holds."""
        return len(self.mes)

    @property
    def width(self) -> int:
        """R, the places of each row."""
        return int(self.hops.shape[1])

    @property
    def row_bytes(self) -> int:
        """The memory one row's places take, bytes: every column's (R places each).

        What a run's blocks are sized by (``protocol.runs.next_block_size``): a
        process's tables hold a row per FLS, as wide as the fullest row needs.
        """
        return self._row_bytes

    def found(self, row: int | None = None) -> NDArray[np.bool_]:
        """Which places of row ``row`` (R,), or of every row (F, R), hold a label."""
        at = slice(None) if row is None else row
        # A label is found at its first candidate, so its hops are finite.
        return np.isfinite(self.hops[at]) if self.direct else self.keys[at] != EMPTY

    def sources_of(self, rows: IntArray | int, places: IntArray) -> IntArray:
        """The sources of the labels at ``places`` of ``rows``."""
        if self.direct and self.run_ids is not None:
            return self.run_ids[np.asarray(places, dtype=np.int64)]
        if self.direct:
            return np.asarray(places, dtype=np.int64) + self.span[0]
        return np.asarray(self.keys[rows, places], dtype=np.int64)

    def columns(self) -> Columns:
        return Columns(
            self.keys, self.sent, self.hops, self.length, self.error, self.pred, self.occupied
        )

    def places(self, row: int) -> IntArray:
        """The taken places of row ``row``, by source."""
        taken = np.flatnonzero(self.found(row))
        return taken if self.direct else taken[np.argsort(self.keys[row, taken], kind="stable")]

    def add_many(self, rows: IntArray, sources: IntArray) -> IntArray:
        """The places of ``sources`` (M,) in ``rows`` (M,, distinct), taken: their labels
        not found yet."""
        need = int(self.occupied[rows].max(initial=0)) + 1
        if 2 * need > self.width and not self.direct:
            self._widen(need)
        places = _insert(self.keys, rows, sources, self.span[0], self.direct, self.run_ids)
        self.occupied[rows] += 1
        return places

    def _widen(self, need: int) -> None:
        """Rows of ``need`` labels at most half full: every label moves to its new place.

        At least four times as wide each time: a few moves while a search spreads.
        """
        rows, places = np.nonzero(self.found())
        sources = self.sources_of(rows, places)
        old = {name: getattr(self, name)[rows, places] for name in self._names()}
        self.direct, width = self._width_for(max(need, 2 * self.width))
        self._allocate(width)
        moved = _insert(
            self.keys, np.ascontiguousarray(rows), sources, self.span[0], self.direct, self.run_ids
        )
        for name, values in old.items():
            getattr(self, name)[rows, moved] = values

    def _names(self) -> list[str]:
        """The columns besides ``keys``."""
        return [name for name in table_columns(self.fits) if name != "keys"]

    def close(self, sources: IntArray) -> None:
        """Stop relaying and keeping the labels of ``sources`` (ids: their searches ended).

        Closing stays closed, so the same array again (a control's ``finished``, which
        a packed process closes for its shared table and then for each FLS) does nothing.
        """
        if sources is self._last_closed:
            return
        self._last_closed = sources
        sources = np.asarray(sources, dtype=np.int64)
        sources = sources[(sources >= self.span[0]) & (sources < self.span[1])]
        if not len(sources):
            return
        if not len(self.closed):
            self.closed = np.zeros(self.id_space, dtype=bool)
        self.closed[sources] = True

    def relax(self, rows: IntArray, order: int, heard: HeardLabels) -> tuple[IntArray, Changes]:
        """Relax ``rows`` (table rows, in order) through ``heard`` in one compiled pass.

        Returns (starts, changes): row ``rows[k]``'s bettered places are
        ``changes[starts[k]:starts[k + 1]]``.
        """
        rows = np.asarray(rows, dtype=np.int64)
        change_starts = np.zeros(len(rows) + 1, dtype=np.int64)
        # Room for as many changes as the last call's, which the next round's resemble.
        size = max(64, 2 * len(rows), self._changes_last)
        changes = Changes(*(np.empty(size, dtype=np.int64) for _ in range(3)))
        won = self._won()
        resume = np.full(2, -1, dtype=np.int64)
        done, filled = 0, 0
        while done < len(rows):
            done, filled, need = relax_rows(
                rows,
                done,
                self.mes,
                order,
                self.span_array,
                self.run_ids,
                self.slots,
                self.link_starts,
                self.links,
                heard,
                self.closed,
                self.columns(),
                changes,
                filled,
                change_starts,
                won,
                resume,
            )
            if done < len(rows) and need:
                won = self._widened(need, rows, done, change_starts, changes, filled, won)
            elif done < len(rows):
                size = 2 * size + self.width
                changes = Changes(*(_grown(one, size) for one in changes))
        self._changes_last = filled
        return change_starts, Changes(*(one[:filled] for one in changes))

    def _won(self) -> Changes:
        """The relaxation's record of the row in hand, by place: none yet."""
        width = self.width
        return Changes(np.zeros(0, dtype=np.int64), np.full(width, -1), np.zeros(width, int))

    def _widened(
        self,
        need: int,
        rows: IntArray,
        done: int,
        change_starts: IntArray,
        changes: Changes,
        filled: int,
        won: Changes,
    ) -> Changes:
        """Widen for ``need`` in the middle of a relaxation: the changes so far (rows
        ``rows[:done]``, and ``rows[done]``'s from ``change_starts[done]``) and the row in
        hand's winners move to their labels' new places; its winners, returned."""
        counts = np.diff(change_starts[: done + 1])
        changed_rows = np.concatenate(
            [np.repeat(rows[:done], counts), np.full(filled - change_starts[done], rows[done])]
        )
        sources = self.sources_of(changed_rows, changes.places[:filled])
        in_hand = np.flatnonzero(won.labels >= 0)
        in_hand_sources = self.sources_of(rows[done], in_hand)
        self._widen(need)
        changes.places[:filled] = _insert(
            self.keys, changed_rows, sources, self.span[0], self.direct, self.run_ids
        )
        moved = _insert(
            self.keys, np.full(len(in_hand), rows[done]), in_hand_sources, self.span[0],
            self.direct, self.run_ids,
        )  # fmt: skip
        widened = self._won()
        widened.labels[moved], widened.links[moved] = won.labels[in_hand], won.links[in_hand]
        return widened

    def due_inputs(
        self, row: int | None, order: int
    ) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_], NDArray[np.bool_]]:
        """What :func:`.due.due_places` reads of row ``row``, or of every row: the ``order``'s
        primary costs, found, sent, and closed (by place, (R,) where every row shares it)."""
        at = slice(None) if row is None else row
        found = self.found(row)
        if not len(self.closed):
            closed = np.zeros(self.width, dtype=bool)
        elif self.direct and self.run_ids is not None:  # a place is its source's slot in a row
            closed = self.closed[self.run_ids]
        elif self.direct:
            closed = self.closed[self.span[0] : self.span[1]]
        else:
            closed = self.closed[np.where(found, self.keys[at], 0)] & found
        primary = (self.hops, self.length, self.error)[order][at]
        return primary, found, self.sent[at], closed

    @classmethod
    def merged(cls, parts: Sequence[tuple[LabelTable, int]]) -> LabelTable:
        """One table of ``parts`` (table, row): part k's labels become row k."""
        first = parts[0][0]
        row_hops: list[RowHops] | None = None
        link_starts: IntArray | None = None
        links: Links | None = None
        if any(table.rows_links.made for table, _ in parts):
            link_starts, links = joined_links([table.rows_links.row(row) for table, row in parts])
        else:  # made for all rows at once when first needed, no row's alone before
            row_hops = [table.rows_links.hops(row) for table, row in parts]
        taken = [table.places(row) for table, row in parts]
        counts = np.array([len(at) for at in taken], dtype=np.int64)
        merged = cls(
            np.array([table.mes[row] for table, row in parts], dtype=np.int64),
            link_starts,
            links,
            first.span,
            first.id_space,
            first.fits,
            need=int(counts.max(initial=1)),
            sources=first.run_ids,
            row_hops=row_hops,
        )
        rows = np.repeat(np.arange(len(parts), dtype=np.int64), counts)
        values = {
            name: np.concatenate(
                [
                    getattr(table, name)[row, at]
                    for (table, row), at in zip(parts, taken, strict=True)
                ]
            )
            for name in merged._names()
        }
        sources = np.concatenate(
            [table.sources_of(row, at) for (table, row), at in zip(parts, taken, strict=True)]
        )
        places = _insert(merged.keys, rows, sources, first.span[0], merged.direct, merged.run_ids)
        for name, column in values.items():
            getattr(merged, name)[rows, places] = column
        merged.occupied[:] = counts
        closed = [table.closed for table, _ in parts if len(table.closed)]
        if closed:
            merged.closed = np.logical_or.reduce(closed)
        return merged


def _grown(values: IntArray, size: int) -> IntArray:
    """``values`` in an array of ``size``, the rest unset."""
    bigger = np.empty(size, dtype=values.dtype)
    bigger[: len(values)] = values
    return bigger
