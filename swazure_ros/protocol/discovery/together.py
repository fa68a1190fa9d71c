"""A process's FLSs stepped together: one compiled relaxation and one pick a round.

A packed process hosts hundreds or thousands of FLSs, each with its own
:class:`~.search.PathSearch`. Hearing a round's offers and picking the
labels due are the same work in every one of them, so the process does them
for all at once (:func:`hear_together`, :func:`pick_together`), over arrays
whose rows are the FLSs' own labels. What each FLS holds, offers and
reports is what stepping it alone gives: its results, paths and messages
stay its own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...core import csr, jit
from ...core.arrays import FloatArray, IntArray
from .messages import RoundOffers
from .search import (
    HeardLabels,
    Links,
    PathSearch,
    SlotLabels,
    _relax,
    heard_labels,
    labels_due,
    source_slots,
)


@jit.kernel(cache=True, nogil=True)
def _relax_each(
    mes: IntArray,
    order: int,
    first: int,
    link_starts: IntArray,
    links: Links,
    heard: HeardLabels,
    sent: NDArray[np.bool_],
    hops: FloatArray,
    length: FloatArray,
    error: FloatArray,
    pred: IntArray,
) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """:func:`_relax` for F FLSs in one call: FLS ``mes[f]`` has row f of the (F, S) labels
    and the links ``link_starts[f]:link_starts[f + 1]`` of ``links``.

    Returns (starts (F + 1,), slots, labels, links): FLS f's changed slots are
    ``slots[starts[f]:starts[f + 1]]``, each with its winning label and its link
    (an index into the FLS's own links), as :func:`_relax` leaves them.
    """
    count, slot_count = hops.shape
    won_label = np.full(slot_count, -1, dtype=np.int64)
    won_link = np.zeros(slot_count, dtype=np.int64)
    starts = np.zeros(count + 1, dtype=np.int64)
    capacity = max(16, count)
    slots = np.empty(capacity, dtype=np.int64)
    labels = np.empty(capacity, dtype=np.int64)
    through = np.empty(capacity, dtype=np.int64)
    filled = 0
    for row in range(count):
        low, high = link_starts[row], link_starts[row + 1]
        own = Links(links.ids[low:high], links.weights[low:high], links.errors[low:high])
        labelled = SlotLabels(sent[row], hops[row], length[row], error[row], pred[row])
        changed = _relax(mes[row], order, first, own, heard, labelled, won_label, won_link)
        if filled + len(changed) > capacity:
            capacity = 2 * (filled + len(changed))
            slots = _grown(slots, capacity)
            labels = _grown(labels, capacity)
            through = _grown(through, capacity)
        for slot in changed:
            slots[filled], labels[filled], through[filled] = slot, won_label[slot], won_link[slot]
            won_label[slot] = -1  # as given to the next FLS's _relax
            filled += 1
        starts[row + 1] = filled
    return starts, slots[:filled], labels[:filled], through[:filled]


@jit.kernel(cache=True, nogil=True)
def _grown(values: IntArray, capacity: int) -> IntArray:
    """``values`` copied into an array of ``capacity`` (the rest unset)."""
    bigger = np.empty(capacity, dtype=values.dtype)
    bigger[: len(values)] = values
    return bigger


class SharedLabels:
    """The labels of F PathSearches of one run and phase, in (F, S) arrays whose rows the
    searches hold as their own: one kernel argument for all (:func:`hear_together`)."""

    def __init__(self, searches: Sequence[PathSearch]) -> None:
        # No reference to the searches: a phase's labels go with its searches, not when
        # the garbage collector finds a cycle.
        self.size = len(searches)
        self.mes = np.array([one.fls_id for one in searches], dtype=np.int64)
        self.link_starts = csr.offsets(np.array([len(one.link_ids) for one in searches]))
        self.links = Links(
            np.concatenate([one.link_ids for one in searches]),
            np.concatenate([one.link_weights for one in searches]),
            np.concatenate([one.link_errors for one in searches]),
        )
        self.sent = np.stack([one.sent for one in searches])
        self.hops = np.stack([one.hops for one in searches])
        self.length = np.stack([one.length for one in searches])
        self.error = np.stack([one.error for one in searches])
        self.pred = np.stack([one.pred for one in searches])
        self.closed = np.stack([one.closed for one in searches])
        for row, one in enumerate(searches):
            # From now on each search's labels are its row: what it writes, the kernel reads.
            one.sent, one.hops, one.length = self.sent[row], self.hops[row], self.length[row]
            one.error, one.pred, one.closed = self.error[row], self.pred[row], self.closed[row]
            one._shared, one._row = self, row

    def holds(self, searches: Sequence[PathSearch]) -> bool:
        """Whether these are the searches whose rows this holds, in this order."""
        return len(searches) == self.size and all(
            one._shared is self and one._row == row for row, one in enumerate(searches)
        )


def _shared_labels(searches: Sequence[PathSearch]) -> SharedLabels | None:
    """The shared labels of ``searches``, made if need be; None when their runs differ."""
    if len({(one.first_source, len(one.hops), one.order, one.width) for one in searches}) != 1:
        return None
    shared = searches[0]._shared
    if isinstance(shared, SharedLabels) and shared.holds(searches):
        return shared
    return SharedLabels(searches)


def pick_together(searches: Sequence[PathSearch], round_: int, closed: IntArray) -> None:
    """Close the sources ``closed`` (ids) and pick the labels each of ``searches`` offers in
    round ``round_``, for all at once; :meth:`PathSearch.offer` then sends them.

    Searches that differ in their runs pick their own when they offer.
    """
    shared = _shared_labels(searches)
    if shared is None:
        return
    first = searches[0]
    shared.closed[:, source_slots(closed, first.first_source, shared.hops.shape[1])] = True
    labels = SlotLabels(shared.sent, shared.hops, shared.length, shared.error, shared.pred)
    unsent, due = labels_due(labels, shared.closed, first.order, first.width, round_)
    rows, slots = np.nonzero(due)  # row by row, each row's slots in order
    shared.sent[rows, slots] = True
    starts = csr.offsets(np.bincount(rows, minlength=len(searches)))
    counts = unsent.sum(axis=1).tolist()
    for row, one in enumerate(searches):
        one._picked = (round_, slots[starts[row] : starts[row + 1]], counts[row])


def hear_together(searches: Sequence[PathSearch], heard: RoundOffers) -> None:
    """Every one of ``searches`` hears ``heard`` (:meth:`PathSearch.hear`), their labels
    relaxed in one compiled call: a process steps its FLSs together.

    The searches of one run and phase (one slot range and policy) share their
    label arrays from their first round heard together on; each keeps its
    own labels, results and paths, and ends as hearing alone would leave it.
    Searches that differ in their runs are heard one by one.
    """
    searches = [one for one in searches if one._last_heard is not heard]
    shared = _shared_labels(searches) if searches else None
    if shared is None:
        for one in searches:
            one.hear(heard)
        return
    for one in searches:
        one._hear_first(heard)
    starts, changed, labels, links = _relax_each(
        shared.mes,
        searches[0].order,
        searches[0].first_source,
        shared.link_starts,
        shared.links,
        heard_labels(heard),
        shared.sent,
        shared.hops,
        shared.length,
        shared.error,
        shared.pred,
    )
    for row in np.flatnonzero(np.diff(starts)).tolist():
        rows = slice(starts[row], starts[row + 1])
        searches[row]._take_changes(heard, changed[rows], labels[rows], links[rows])
