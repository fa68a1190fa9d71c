"""The offers that labels came through, and the offers made of labels in one pass.

A label holds no path of its own. It names the offers that bettered it last
(a key of an :class:`OffersHeard`, ``LabelTable.via_offers``) and its label
there (``via_label``): its path is its sender's path there, then its own FLS.
A search stepped alone keeps a book of its own; the searches a process steps
together share one, as they share their table (:mod:`.together`), so that
:func:`offers_of` reads the labels and paths of every FLS that the process
speaks for in a round at once, and each FLS's offer is a view of them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...core import csr, jit
from ...core.arrays import FloatArray, IdArray, IntArray
from .labels import LabelTable
from .messages import Offer, RoundOffers

#: How many rounds' offers a book keeps before it drops those no unsent label needs.
KEPT = 8


class OffersHeard:
    """The offers heard that some label of a table came through, by key (``offers``)."""

    def __init__(self) -> None:
        self.offers: dict[int, RoundOffers] = {}
        self._next = 0

    def key(self, heard: RoundOffers) -> int:
        """The key of ``heard``, kept from now on; the key given last when it was ``heard``
        too (the rows of a table bettered by one round's offers share it)."""
        last = self._next - 1
        if last in self.offers and self.offers[last] is heard:
            return last
        self.offers[self._next] = heard
        self._next += 1
        return self._next - 1

    def paths(self, via: IntArray, label: IntArray, ends: IntArray) -> tuple[IntArray, IdArray]:
        """The paths of L labels, each its sender's path then its own FLS.

        Parameters
        ----------
        via, label : (L,) array of int
            The key of the offers that bettered each label (-1: its FLS is the
            source, whose path is itself) and its label there.
        ends : (L,) array of int
            The id of each label's FLS.

        Returns
        -------
        offsets : (L + 1,) array of int
        ids : array of uint32
            FLS ids, source first.
        """
        # Compiled passes over the L labels, a few per round's offers kept: a numpy
        # version made a dozen temporaries of L (a round's L reaches millions), and
        # sorting ``via`` to list its keys cost more than the copying.
        start = np.zeros(len(via), dtype=np.int64)
        length = np.zeros(len(via), dtype=np.int64)
        keys = self._keys_in(via)
        for key in keys:
            _spans(self.offers[key].path_offsets, via, label, key, start, length)
        path_offsets = csr.offsets(length + 1)
        # FLS ids are uint32 on the wire: a round's paths (tens of millions of ids) in half.
        path_ids = np.empty(int(path_offsets[-1]), dtype=np.uint32)
        for key in keys:
            _copy_key(self.offers[key].path_ids, via, key, start, length, path_offsets, path_ids)
        _place_ends(ends, path_offsets, path_ids)
        return path_offsets, path_ids

    def add_vectors(self, via: IntArray, label: IntArray, vectors: FloatArray) -> None:
        """Add to L labels' hop vectors their senders' vectors in the offers they came
        through: each label's vector, the one it won with.

        Parameters
        ----------
        via, label : (L,) array of int
            As :meth:`paths` takes them (-1: the label's FLS is the source, whose
            vector stays as given, 0).
        vectors : (L, 3) array of float
            Each label's hop, sender to its FLS, cm; summed in place, the sender's first
            (as the label's sum was made when it won).
        """
        for key in self._keys_in(via):
            _add_key_vectors(self.offers[key].vectors, via, label, key, vectors)

    def _keys_in(self, via: IntArray) -> list[int]:
        """The keys that ``via`` names (-1, no key, left out), each once, in order."""
        present = np.zeros(self._next, dtype=np.bool_)
        _mark_keys(via, present)
        return np.flatnonzero(present).tolist()

    def forget(self, table: LabelTable) -> None:
        """Drop the offers that no unsent label of ``table`` comes through, looked for only
        once more than :data:`KEPT` are kept."""
        if len(self.offers) > KEPT:
            via = table.via_offers
            needed = np.zeros(self._next, dtype=bool)
            needed[via[~table.sent & (via >= 0)]] = True
            for key in [key for key in self.offers if not needed[key]]:
                del self.offers[key]

    @classmethod
    def merged(cls, books: Sequence[OffersHeard]) -> tuple[OffersHeard, IntArray]:
        """One book of ``books`` (one per row of a merged table, shared ones given again),
        and what to add to each row's keys (B,) to find their offers in it."""
        book = cls()
        bases: dict[int, int] = {}
        for one in books:
            if id(one) not in bases:
                bases[id(one)] = book._next
                book.offers.update({book._next + key: heard for key, heard in one.offers.items()})
                book._next += one._next
        return book, np.array([bases[id(one)] for one in books], dtype=np.int64)


@jit.kernel(cache=True, nogil=True)
def _mark_keys(via: IntArray, present: NDArray[np.bool_]) -> None:
    """Mark the keys ``via`` names (-1, no key, is left out)."""
    for key in via:
        if key >= 0:
            present[key] = True


@jit.kernel(cache=True, nogil=True)
def _spans(
    offsets: IntArray, via: IntArray, label: IntArray, key: int,
    start: IntArray, length: IntArray,
) -> None:  # fmt: skip
    """Where each label through offers ``key`` finds its sender's path in them (``offsets``
    of those offers): its start and length."""
    for row in range(len(via)):
        if via[row] == key:
            first = offsets[label[row]]
            start[row] = first
            length[row] = offsets[label[row] + 1] - first


@jit.kernel(cache=True, nogil=True)
def _copy_key(
    values: IdArray, via: IntArray, key: int, starts: IntArray, counts: IntArray,
    out_starts: IntArray, out: IdArray,
) -> None:  # fmt: skip
    """Copy the sender's path of each label through offers ``key`` (``counts[k]`` ids of
    their ``values`` from ``starts[k]``) to ``out`` from ``out_starts[k]`` on."""
    for row in range(len(via)):
        if via[row] == key:
            source, target = starts[row], out_starts[row]
            for step in range(counts[row]):
                out[target + step] = values[source + step]


@jit.kernel(cache=True, nogil=True)
def _add_key_vectors(
    values: FloatArray, via: IntArray, label: IntArray, key: int, vectors: FloatArray
) -> None:
    """Add to the vector of each label through offers ``key`` its sender's there."""
    for row in range(len(via)):
        if via[row] == key:
            for axis in range(3):
                vectors[row, axis] = values[label[row], axis] + vectors[row, axis]


@jit.kernel(cache=True, nogil=True)
def _place_ends(ends: IntArray, out_starts: IntArray, out: IdArray) -> None:
    """End each path with its label's own FLS, ``ends[k]``: the last id before the next."""
    for row in range(len(ends)):
        out[out_starts[row + 1] - 1] = ends[row]


def _gathered(
    table: LabelTable, rows: IntArray, places: IntArray
) -> tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray, FloatArray]:
    """The labels at ``places`` of ``rows`` (L,): the offers' keys and labels they came
    through, hops, lengths, errors and the vectors (L, 3) of their last hops (0 for a
    source's own label), in one pass over the table."""
    size = len(rows)
    via, via_label, hops = (np.empty(size, dtype=np.int64) for _ in range(3))
    lengths, errors, vectors = np.empty(size), np.empty(size), np.empty((size, 3))
    # A table whose links were never made relaxed no label: every label is its source's.
    made = table.rows_links.made
    link_starts = table.link_starts if made else np.zeros(table.size + 1, dtype=np.int64)
    link_vectors = table.links.vectors if made else np.zeros((0, 3))
    # One compiled pass: six numpy gathers each walked the L (row, place) pairs again.
    _gather(rows, places, table.via_offers, table.via_label, table.via_link, table.hops,
            table.length, table.error, link_starts, link_vectors, via, via_label, hops,
            lengths, errors, vectors)  # fmt: skip
    return via, via_label, hops, lengths, errors, vectors


@jit.kernel(cache=True, nogil=True)
def _gather(
    rows: IntArray, places: IntArray, via_offers: IntArray, via_labels: IntArray,
    via_links: IntArray, table_hops: FloatArray, table_lengths: FloatArray,
    table_errors: FloatArray, link_starts: IntArray, link_vectors: FloatArray,
    via: IntArray, via_label: IntArray, hops: IntArray, lengths: FloatArray,
    errors: FloatArray, vectors: FloatArray,
) -> None:  # fmt: skip
    """:func:`_gathered`'s pass: label k is place ``places[k]`` of row ``rows[k]``."""
    for k in range(len(rows)):
        row, place = rows[k], places[k]
        via[k], via_label[k] = via_offers[row, place], via_labels[row, place]
        hops[k] = np.int64(table_hops[row, place])
        lengths[k], errors[k] = table_lengths[row, place], table_errors[row, place]
        if via[k] < 0:  # a source's own label: no hop
            vectors[k] = 0.0
            continue
        link = link_starts[row] + via_links[row, place]
        for axis in range(3):
            vectors[k, axis] = link_vectors[link, axis]


def offers_of(
    table: LabelTable,
    book: OffersHeard,
    members: IntArray,
    due: tuple[IntArray, IntArray],
    beyond: tuple[IntArray, IntArray],
    pending: Sequence[bool],
) -> list[Offer]:
    """The offers of rows ``members`` (sorted) of ``table``, read in one pass.

    Parameters
    ----------
    table, book : LabelTable, OffersHeard
        The labels and the offers they came through.
    members : (M,) array of int
        Rows that offer, one :class:`.messages.Offer` each, in this order.
    due : ((L,), (L,)) arrays of int
        Rows and places of the labels sent, by row, each row's in the order
        its FLS sends them (by source).
    beyond : ((B,), (B,)) arrays of int
        Rows and places of the labels held beyond the pass's reach.
    pending : (M,) bools
        Whether each offering FLS holds labels still to send in this pass.

    Returns
    -------
    list of Offer
        Their fields are views of arrays shared by the M offers; ``finished``
        and the readings are the caller's to set.
    """
    rows, places = due
    via, via_label, hops, lengths, errors, vectors = _gathered(table, rows, places)
    book.add_vectors(via, via_label, vectors)
    path_offsets, path_ids = book.paths(via, via_label, table.mes[rows])
    book.forget(table)
    sources = table.sources_of(rows, places)
    unbiased = table.unbiased[rows, places] if table.fits else None
    covariances = table.covariance[rows, places] if table.fits else None
    beyond_ids = table.sources_of(*beyond)
    order = np.lexsort((beyond_ids, beyond[0]))
    beyond_rows, beyond_ids = beyond[0][order], beyond_ids[order]
    bounds = zip(
        np.searchsorted(rows, members).tolist(),
        np.searchsorted(rows, members, side="right").tolist(),
        np.searchsorted(beyond_rows, members).tolist(),
        np.searchsorted(beyond_rows, members, side="right").tolist(),
        pending,
        strict=True,
    )
    offers = []
    for first, end, first_beyond, end_beyond, more in bounds:
        offsets, ids = csr.span(path_offsets, path_ids, first, end)
        labels = slice(first, end)
        offers.append(
            Offer(
                source_ids=sources[labels],
                hops=hops[labels],
                lengths=lengths[labels],
                errors=errors[labels],
                vectors=vectors[labels],
                path_offsets=offsets,
                path_ids=ids,
                pending=bool(more),
                unbiased=None if unbiased is None else unbiased[labels],
                covariances=None if covariances is None else covariances[labels],
                beyond_ids=beyond_ids[first_beyond:end_beyond],
                label_bytes=table.row_bytes,
            )
        )
    return offers
