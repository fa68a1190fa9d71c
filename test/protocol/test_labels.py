"""A LabelTable: a place per source that reached an FLS, found again after every widening."""

from __future__ import annotations

import numpy as np

from swazure_ros.protocol.discovery.labels import LENGTH_FIRST, HeardLabels, LabelTable
from swazure_ros.protocol.discovery.links import Links
from swazure_ros.protocol.discovery.places import place_bytes, table_columns


def table_of(mes, link_ids, weight, span):
    """A table of FLSs ``mes``, FLS k relaying from ``link_ids[k]``, every hop ``weight`` cm."""
    links = np.array([sender for own in link_ids for sender in own], dtype=np.int64)
    return LabelTable(
        np.array(mes),
        np.concatenate([[0], np.cumsum([len(own) for own in link_ids])]).astype(np.int64),
        Links(links, np.full(len(links), weight), np.zeros(len(links)), np.zeros((len(links), 3))),
        span,
        id_space=span[1],
        fits=False,
    )


def heard(offers):
    """Offers {sender: (sources, length)}: each source's label one hop from it."""
    senders = sorted(offers)
    sources = [np.asarray(offers[s][0], dtype=np.int64) for s in senders]
    counts = [len(one) for one in sources]
    lengths = np.concatenate([np.full(len(one), offers[s][1]) for s, one in zip(senders, sources)])
    total = sum(counts)
    return HeardLabels(
        np.array(senders, dtype=np.int64),
        np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        np.concatenate(sources),
        np.ones(total, dtype=np.int64),
        lengths,
        np.zeros(total),
    )


def labels_of(table, row):
    places = table.places(row)
    return dict(
        zip(
            table.sources_of(row, places).tolist(),
            zip(table.length[row, places].tolist(), table.pred[row, places].tolist()),
        )
    )


def test_a_row_widens_as_sources_reach_it_and_keeps_every_label():
    # FLS 900 hears FLS 5 offer 3 sources of a run of 1,000; FLS 901 hears 5 and 6 offer
    # 41: its row widens once 900's is done, whose changes keep their labels.
    table = table_of([900, 901], [[5], [5, 6]], 7.0, (0, 1000))
    offers = heard({5: (range(3), 7.0), 6: (range(3, 41), 7.0)})
    starts, changes = table.relax(np.array([0, 1]), LENGTH_FIRST, offers)
    assert np.diff(starts).tolist() == [3, 41]  # every label is new, so changed
    assert not table.direct and 2 * 41 <= table.width < 1000
    rows = np.repeat([0, 1], np.diff(starts))
    assert sorted(table.sources_of(rows[:3], changes.places[:3]).tolist()) == [0, 1, 2]
    assert sorted(table.sources_of(rows[3:], changes.places[3:]).tolist()) == list(range(41))
    assert labels_of(table, 0) == {source: (14.0, 5) for source in range(3)}
    assert labels_of(table, 1) == {s: (14.0, 5 if s < 3 else 6) for s in range(41)}
    # Then 6 offers 31 sources to 901 by a shorter hop: 6.5 + 7 cm against 7 + 7 cm.
    table.links.weights[1:] = 6.5
    table.relax(np.array([1]), LENGTH_FIRST, heard({6: (range(30, 61), 7.0)}))
    expected = {source: (14.0, 5 if source < 3 else 6) for source in range(30)}
    expected.update({source: (13.5, 6) for source in range(30, 61)})
    assert labels_of(table, 1) == expected
    assert table.found().sum(axis=1).tolist() == [3, 61]  # no FLS holds 1,000 places


def test_a_row_is_a_slot_per_source_once_a_hash_would_be_half_as_wide():
    table = table_of([3], [[1]], 7.0, (100, 164))
    table.relax(np.array([0]), LENGTH_FIRST, heard({1: ([100, 120, 163], 7.0)}))
    assert not table.direct and table.width == 8
    table.relax(np.array([0]), LENGTH_FIRST, heard({1: (range(130, 150), 7.0)}))
    assert table.direct and table.width == 64
    assert table.places(0).tolist() == [0, 20, *range(30, 50), 63]  # source - first
    assert labels_of(table, 0) == {s: (14.0, 1) for s in [100, 120, *range(130, 150), 163]}


def test_a_sent_label_is_final_even_against_a_cheaper_offer():
    # Sent labels are final (buckets), and the relaxation reads a label's cost before it
    # reads `sent`: a cheaper offer of a sent source changes nothing, in a hash or a slot.
    for span in ((0, 1000), (0, 4)):
        table = table_of([3], [[1, 2]], 7.0, span)
        table.relax(np.array([0]), LENGTH_FIRST, heard({1: ([0, 1, 2], 7.0)}))
        assert table.direct is (span[1] == 4)
        table.sent[0, table.places(0)[table.sources_of(0, table.places(0)) == 1]] = True
        starts, changes = table.relax(np.array([0]), LENGTH_FIRST, heard({2: ([1, 2], 1.0)}))
        assert table.sources_of(np.zeros(1, dtype=np.int64), changes.places[:1]).tolist() == [2]
        assert np.diff(starts).tolist() == [1]
        assert labels_of(table, 0) == {0: (14.0, 1), 1: (14.0, 1), 2: (8.0, 2)}


def test_a_closed_source_is_neither_relaxed_nor_kept():
    table = table_of([3], [[1]], 7.0, (0, 500))
    table.close(np.array([7, 9, 600]))  # 600 is not this run's
    table.relax(np.array([0]), LENGTH_FIRST, heard({1: ([5, 7, 8, 9, 600], 7.0)}))
    assert sorted(labels_of(table, 0)) == [5, 8]


def test_a_label_s_sender_is_kept_in_32_bits_up_to_the_largest_id_on_the_wire():
    # Senders above int32's range, as uint32 ids on the wire may be: at equal cost the
    # smaller id wins the tie, as the engine's smallest predecessor does.
    low, high = 3_000_000_000, 4_294_967_294
    table = table_of([3], [[high, low]], 7.0, (0, 4))
    table.relax(np.array([0]), LENGTH_FIRST, heard({low: ([0, 1], 7.0), high: ([1, 2], 7.0)}))
    assert labels_of(table, 0) == {0: (14.0, low), 1: (14.0, low), 2: (14.0, high)}
    assert table.pred.itemsize == table.via_offers.itemsize == table.via_label.itemsize == 4


def test_a_place_takes_the_bytes_of_what_the_table_lays_out_for_it():
    hops = table_of([3, 4], [[1], [1]], 7.0, (0, 8)).links
    for fits in (False, True):
        # A run of 8 sources: a slot each; of 1,000: a hash of 8 places a row, keys kept.
        for sources, direct in ((8, True), (1000, False)):
            starts = np.array([0, 1, 2])
            table = LabelTable(np.array([3, 4]), starts, hops, (0, sources), sources, fits)
            assert table.direct is direct and table.width == 8
            laid_out = sum(getattr(table, name).nbytes for name in table_columns(fits))
            places = table.size * table.width
            assert laid_out == places * place_bytes(direct, fits) == table.size * table.row_bytes
