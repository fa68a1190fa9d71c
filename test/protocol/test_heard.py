"""The offers labels came through: keys, paths read from them, books merged and pruned."""

from __future__ import annotations

import numpy as np

from swazure_ros.protocol.discovery.heard import KEPT, OffersHeard, offers_of
from swazure_ros.protocol.discovery.labels import LabelTable
from swazure_ros.protocol.discovery.links import Links
from swazure_ros.protocol.discovery.messages import Offer, RoundOffers


def offers_from(sender, paths, vectors=None):
    """One round's offers: ``sender``'s labels, one per path (FLS ids, source first), their
    vectors ``vectors`` (zeros if None)."""
    count = len(paths)
    offer = Offer(
        source_ids=np.array([path[0] for path in paths], dtype=np.int64),
        hops=np.array([len(path) - 1 for path in paths], dtype=np.int64),
        lengths=np.ones(count),
        errors=np.zeros(count),
        vectors=np.zeros((count, 3)) if vectors is None else np.array(vectors, dtype=float),
        path_offsets=np.concatenate([[0], np.cumsum([len(p) for p in paths])]).astype(np.int64),
        path_ids=np.array([fls for path in paths for fls in path], dtype=np.int64),
    )
    return RoundOffers.of([(sender, offer)])


def test_a_label_s_path_is_its_sender_s_path_there_then_its_own_fls():
    book = OffersHeard()
    first = book.key(offers_from(5, [(1, 5), (2, 7, 5)]))
    second = book.key(offers_from(6, [(3, 6)]))
    offsets, ids = book.paths(
        np.array([first, second, -1, first]), np.array([1, 0, -1, 0]), np.array([9, 9, 4, 8])
    )
    paths = [ids[offsets[k] : offsets[k + 1]].tolist() for k in range(4)]
    # A label with no offers behind it is its FLS's own: the source itself.
    assert paths == [[2, 7, 5, 9], [3, 6, 9], [4], [1, 5, 8]]


def test_one_round_s_offers_keep_one_key_for_every_row_they_better():
    book = OffersHeard()
    heard, later = offers_from(5, [(1, 5)]), offers_from(5, [(2, 5)])
    assert book.key(heard) == book.key(heard) == 0
    assert book.key(later) == 1
    assert book.offers == {0: heard, 1: later}


def test_books_merged_give_each_row_the_keys_of_its_own_book():
    one, other = OffersHeard(), OffersHeard()
    a, b, c = (offers_from(5, [(k, 5)]) for k in (1, 2, 3))
    one.key(a), one.key(b), other.key(c)
    book, bases = OffersHeard.merged([one, other, one])
    assert bases.tolist() == [0, 2, 0]
    assert book.offers == {0: a, 1: b, 2: c}
    # The next offers heard together take a key of their own.
    assert book.key(offers_from(5, [(4, 5)])) == 3


def test_offers_no_unsent_label_comes_through_are_dropped_once_more_than_kept():
    table = LabelTable(
        np.array([0]),
        np.array([0, 0]),
        Links(np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros((0, 3))),
        (0, 4),
        4,
        fits=False,
    )
    book = OffersHeard()
    heard = [offers_from(5, [(k, 5)]) for k in range(KEPT + 2)]
    for offers in heard[:KEPT]:
        book.key(offers)
    table.via_offers[0] = [3, KEPT - 1, KEPT - 1, -1]
    table.sent[0] = [False, True, False, False]
    book.forget(table)
    assert len(book.offers) == KEPT  # not more than kept: none looked for
    book.key(heard[KEPT])
    book.forget(table)
    # Place 0 (unsent) comes through 3, place 2 (unsent) through KEPT - 1; place 1 is sent.
    assert sorted(book.offers) == [3, KEPT - 1]


def test_offers_read_each_row_s_due_labels_at_their_places():
    # Two rows of nine places (sources 0-8); each label's columns say where it sits. Each
    # row relays from FLSs 4 and 5; its hop from 5 reads (0.5, 0.5, 0.5) at FLS 7, (10, -10,
    # 20) at FLS 8.
    hop_vectors = [[9.0, 9.0, 9.0], [0.5, 0.5, 0.5], [9.0, 9.0, 9.0], [10.0, -10.0, 20.0]]
    table = LabelTable(
        np.array([7, 8]),
        np.array([0, 2, 4]),
        Links(np.array([4, 5, 4, 5]), np.ones(4), np.zeros(4), np.array(hop_vectors)),
        (0, 9),
        9,
        fits=False,
    )
    rows, places = np.array([0, 0, 1, 1]), np.array([3, 1, 2, 8])
    for row, place in zip(rows, places, strict=True):
        at = 10 * row + place
        table.hops[row, place], table.length[row, place] = at + 1, at + 0.5
        table.error[row, place] = at + 0.25
    # Each came through FLS 5's offer of its source (label k of that offer: source k, its
    # vector (k, -k, 2k)), by the row's second link; but FLS 8's own label.
    book = OffersHeard()
    key = book.key(offers_from(5, [(k, 5) for k in range(4)], [[k, -k, 2 * k] for k in range(4)]))
    table.via_offers[rows, places] = [key, key, key, -1]
    table.via_label[rows, places] = [3, 1, 2, -1]
    table.via_link[rows, places] = [1, 1, 1, -1]
    no_labels = (np.zeros(0, np.int64), np.zeros(0, np.int64))
    first, second = offers_of(
        table, book, np.array([0, 1]), (rows, places), no_labels, [False, True]
    )
    assert first.source_ids.tolist() == [3, 1] and second.source_ids.tolist() == [2, 8]
    assert first.hops.tolist() == [4, 2] and second.hops.tolist() == [13, 19]
    assert first.hops.dtype == np.int64
    assert first.path_ids.dtype == np.uint32  # ids as the wire has them: paths in half
    assert first.lengths.tolist() == [3.5, 1.5] and second.errors.tolist() == [12.25, 18.25]
    # A label's vector: its sender's there, then the hop it came through; a source's own, 0.
    assert first.vectors.tolist() == [[3.5, -2.5, 6.5], [1.5, -0.5, 2.5]]
    assert second.vectors.tolist() == [[12, -12, 24], [0, 0, 0]]
    assert [first.path(0), first.path(1)] == [(3, 5, 7), (1, 5, 7)]
    assert [second.path(0), second.path(1)] == [(2, 5, 8), (8,)]
    assert (first.pending, second.pending) == (False, True)
