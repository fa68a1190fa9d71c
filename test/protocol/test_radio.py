"""One process's radio: what its FLSs take of a round, and when a round is acknowledged."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from swazure_ros.protocol.discovery.messages import (
    ANY_VISIBLE,
    END,
    FIT,
    ROUND,
    START,
    SWEET_VISIBLE,
    Broadcast,
    Control,
    FitBlock,
    FitOffer,
    Offer,
    RoundOffers,
    fit_offer,
)
from swazure_ros.protocol.radio import Ack, RadioHub
from swazure_ros.protocol.radio_loss import Delivery, RadioLoss


def offer(*sources):
    """An offer of one-hop labels of ``sources`` (paths source -> sender 9)."""
    count = len(sources)
    return Offer(
        source_ids=np.array(sources, dtype=np.int64),
        hops=np.ones(count, dtype=np.int64),
        lengths=np.full(count, 6.5),
        errors=np.full(count, 0.08),
        vectors=np.zeros((count, 3)),
        path_offsets=np.arange(0, 2 * count + 1, 2, dtype=np.int64),
        path_ids=np.array([fls for source in sources for fls in (source, 9)], dtype=np.int64),
    )


def test_a_round_is_acknowledged_once_every_offer_is_heard():
    radio = RadioHub({0, 1})
    radio.on_control(Control(1, START, expected=4))
    recipients, ack, heard = radio.on_control(Control(1, ROUND, round=0, expected=4))
    assert sorted(recipients) == [0, 1] and ack is None and len(heard) == 0
    for sender in (0, 1, 2):
        assert radio.on_offer(1, 0, sender, offer()) is None
    assert radio.on_offer(1, 0, 3, offer()) == Ack(1, 0, 0, 4)


def test_offers_that_arrive_before_their_round_count_toward_its_ack():
    radio = RadioHub({0, 1})
    radio.on_control(Control(1, START, expected=2))
    radio.on_offer(1, 0, 2, offer())
    radio.on_offer(1, 0, 3, offer())
    _, ack, _ = radio.on_control(Control(1, ROUND, round=0, expected=2))
    assert ack == Ack(1, 0, 0, 2)


def test_the_next_control_hands_over_the_earlier_rounds_offers_only():
    radio = RadioHub({0, 1})
    radio.on_control(Control(1, START, expected=3))
    radio.on_offer(1, 0, 3, offer(5, 6))
    radio.on_offer(1, 0, 2, offer(7))
    radio.on_offer(1, 1, 4, offer(8))  # already round 1's, from a faster process
    _, _, heard = radio.on_control(Control(1, ROUND, round=1, expected=3))
    assert heard.senders.tolist() == [2, 3] and heard.source_ids.tolist() == [7, 5, 6]
    assert heard.labels_of(np.array([3])).tolist() == [1, 2] and heard.path(2) == (6, 9)
    assert heard.paths(np.array([2, 0, 1])) == [(6, 9), (7, 9), (5, 9)]
    assert heard.paths(np.zeros(0, dtype=np.int64)) == []
    _, _, later = radio.on_control(Control(1, END, round=2))
    assert later.senders.tolist() == [4]


def test_departed_flss_are_neither_handed_controls_nor_heard_and_stale_rounds_are_dropped():
    radio = RadioHub({0, 1})
    radio.on_control(Control(1, START, round=0, expected=4))
    radio.on_offer(1, 0, 2, offer(5))
    recipients, _, _ = radio.on_control(Control(1, START, round=3, expected=3, departed_ids=(1,)))
    assert recipients == [0]
    radio.on_offer(1, 3, 1, offer(5))  # from the departed FLS
    radio.on_offer(1, 2, 2, offer(5))  # from before the restart
    radio.on_offer(1, 3, 3, offer(5))
    _, _, heard = radio.on_control(Control(1, ROUND, round=4, expected=3))
    assert heard.senders.tolist() == [3]


def test_a_process_s_own_offers_heard_at_once_are_kept_as_heard_one_by_one():
    # FLS 0 speaks three times (two slots: the third is not kept), 1 has departed, 2 speaks
    # once; 5 is another process's FLS.
    said = [(0, (5,)), (1, (6,)), (0, (7, 8)), (2, (9,)), (0, (4,)), (5, (3,))]
    offers = [Broadcast(1, SWEET_VISIBLE, 0, sender, offer(*sources)) for sender, sources in said]
    radios = [RadioHub({0, 1, 2}), RadioHub({0, 1, 2})]
    for radio in radios:
        radio.on_control(Control(1, START, expected=4, departed_ids=(1,)))
        radio.on_control(Control(1, ROUND, round=0, expected=3))
    at_once = radios[0].on_offers(1, 0, offers[:-1])
    one_by_one = [radios[1].on_offer(1, 0, out.sender, out.offer) for out in offers[:-1]]
    assert at_once is None and one_by_one == [None] * 5  # 5 has not spoken yet
    assert radios[0].on_offers(1, 0, offers[-1:]) == radios[1].on_offer(1, 0, 5, offers[-1].offer)
    # The same offers kept for the round: FLS 0's first two (its slots), not its third.
    kept = [[(one.sender, id(one.offer)) for one in radio._heard[(1, 0)].kept] for radio in radios]
    assert kept[0] == kept[1] and [sender for sender, _ in kept[0]] == [0, 0, 2, 5]
    assert radios[0].on_offers(1, 0, offers[-1:]) is None  # acknowledged once
    tables = [radio.on_control(Control(1, ROUND, round=1, expected=3))[2] for radio in radios]
    assert tables[0].senders.tolist() == tables[1].senders.tolist() == [0, 2, 5]
    assert tables[0].source_ids.tolist() == tables[1].source_ids.tolist() == [5, 9, 3]


def test_the_tally_of_a_round_counts_each_local_sender_s_first_offer():
    radio = RadioHub({0, 2})
    radio.on_control(Control(1, START, expected=2))
    radio.on_control(Control(1, ROUND, round=0, expected=2))
    offers = [
        Broadcast(1, SWEET_VISIBLE, 0, 2, offer(2, 5)),
        Broadcast(1, SWEET_VISIBLE, 0, 0, offer()),
    ]
    again = Broadcast(1, SWEET_VISIBLE, 0, 2, offer(6))
    radio.sent_all([*offers, again], [100, 40, 7])
    sent = radio.take_sent(1, 0)
    assert sent.senders == (0, 2) and sent.labels == 2 and sent.bytes == 140
    assert sent.searching == (2,)  # its own label: 2 searches as a source
    assert radio.take_sent(1, 0).senders == ()  # taken once


def test_a_round_table_gives_each_sender_s_labels():
    table = RoundOffers.of([(4, offer(1)), (2, offer(1, 3)), (9, offer())])
    assert table.senders.tolist() == [2, 4, 9] and len(table) == 3
    assert table.labels_of(np.array([4, 7])).tolist() == [2]
    assert table.labels_of(np.array([2, 4, 9])).tolist() == [0, 1, 2]
    assert table.labels_of(np.array([], dtype=np.int64)).tolist() == []
    # Each label's sender, the empty offers' (2 has none here) passed over.
    table = RoundOffers.of([(4, offer(1)), (2, offer()), (3, offer(1, 3)), (9, offer(5))])
    assert table.senders_of(np.array([0, 1, 2, 3])).tolist() == [3, 3, 4, 9]


def slices(whole, counts):
    """``whole``'s offer cut into offers of ``counts`` labels, each a view of it, in order
    (as a process's offers are, read in one pass)."""
    cuts = np.cumsum([0, *counts])
    offers = []
    for start, end in itertools.pairwise(cuts):
        paths = whole.path_offsets[start : end + 1]
        offers.append(
            Offer(
                source_ids=whole.source_ids[start:end],
                hops=whole.hops[start:end],
                lengths=whole.lengths[start:end],
                errors=whole.errors[start:end],
                vectors=whole.vectors[start:end],
                path_offsets=paths - paths[0],
                path_ids=whole.path_ids[paths[0] : paths[-1]],
            )
        )
    return offers


def copy_of(one):
    """``one`` with every label field a copy of its own."""
    fields = ("source_ids", "hops", "lengths", "errors", "vectors", "path_offsets", "path_ids")
    return Offer(*(np.copy(getattr(one, name)) for name in fields))


def test_a_process_s_own_offers_join_into_its_round_table_without_a_copy():
    whole = offer(1, 3, 5, 6, 8)
    viewed = list(zip([2, 4, 7, 9], slices(whole, [2, 0, 1, 2]), strict=True))
    copied = [(sender, copy_of(one)) for sender, one in viewed]
    table, again = RoundOffers.of(viewed), RoundOffers.of(copied)
    for name in ("senders", "starts", "source_ids", "hops", "lengths", "vectors"):
        assert np.array_equal(getattr(table, name), getattr(again, name)), name
    assert table.paths(np.arange(5)) == again.paths(np.arange(5)) == [
        (1, 9), (3, 9), (5, 9), (6, 9), (8, 9)
    ]  # fmt: skip
    # The labels' fields are the offers' own memory: no copy of a round's labels.
    assert np.shares_memory(table.lengths, whole.lengths)
    assert np.shares_memory(table.vectors, whole.vectors)
    assert not np.shares_memory(again.lengths, whole.lengths)
    # Offers out of order, or of different arrays, are copied as before.
    reversed_ = RoundOffers.of([(9 - sender, one) for sender, one in viewed])
    assert reversed_.source_ids.tolist() == [6, 8, 5, 1, 3]
    assert not np.shares_memory(reversed_.lengths, whole.lengths)


def test_a_lossless_radio_needs_no_repairs():
    senders, receivers = np.arange(100), np.arange(100, 200)
    assert RadioLoss(0.0).deliver(1, 0, senders, receivers) == Delivery(0, 0, 0.0)


def test_a_lossy_radio_repairs_what_it_loses_and_counts_it():
    senders, receivers = np.repeat(np.arange(100), 100), np.tile(np.arange(100), 100)
    delivery = RadioLoss(0.1, seed=3).deliver(7, 2, senders, receivers)
    # About 1000 of 10,000 first deliveries lost, each repaired with a request and a resend
    # (a few requests lost and asked again); none lost on all 12 tries.
    assert delivery.lost == 0 and 1800 < delivery.repairs < 2600 and delivery.latency == 0
    assert RadioLoss(0.1, seed=3).deliver(7, 2, senders, receivers) == delivery
    assert RadioLoss(0.1, seed=4).deliver(7, 2, senders, receivers) != delivery
    # One try and no repairs: what is lost stays lost.
    once = RadioLoss(0.5, seed=3, attempts=1).deliver(7, 2, senders, receivers)
    assert once.repairs == 0 and 4700 < once.lost < 5300


def test_a_slow_radio_delays_the_round_by_its_latest_delivery_within_the_bound():
    senders, receivers = np.repeat(np.arange(100), 100), np.tile(np.arange(100), 100)
    # Delay alone: every broadcast arrives, the last of 10,000 near the longest delay.
    slow = RadioLoss(0.0, seed=3, delay=0.05).deliver(7, 2, senders, receivers)
    assert slow.repairs == 0 and slow.lost == 0 and 0.049 < slow.latency <= 0.05
    # Lost and late: a repaired delivery waits for the broadcast's bound, then a round
    # trip per try; none arrives after the last try's bound.
    both = RadioLoss(0.1, seed=3, delay=0.05).deliver(7, 2, senders, receivers)
    lossy = RadioLoss(0.1, seed=3).deliver(7, 2, senders, receivers)
    assert (both.repairs, both.lost) == (lossy.repairs, lossy.lost)  # delays change no fate
    assert 0.05 < both.latency <= (2 * 12 - 1) * 0.05
    assert RadioLoss(0.1, seed=3, delay=0.05).deliver(7, 2, senders, receivers) == both
    one = RadioLoss(0.0, seed=3, delay=0.05).deliver(7, 2, senders[:1], receivers[:1])
    assert 0 < one.latency < slow.latency


def test_radio_loss_settings_are_checked():
    with pytest.raises(ValueError, match="radio loss"):
        RadioLoss(1.0)
    with pytest.raises(ValueError, match="radio delay"):
        RadioLoss(0.1, delay=-1.0)
    with pytest.raises(ValueError, match="attempts"):
        RadioLoss(0.1, attempts=0)


def test_only_offers_from_other_processes_are_checked_for_plausibility():
    checked = []

    def nothing_is_true(heard, phase):
        checked.append(heard.senders.tolist())
        return np.ones(len(heard), dtype=np.int8)

    radio = RadioHub({0, 1}, check=nothing_is_true)
    radio.on_control(Control(1, START, expected=3))
    radio.on_offer(1, 0, 0, offer(5))  # this process's own FLS
    radio.on_offer(1, 0, 3, offer(7))  # another process's
    _, _, heard = radio.on_control(Control(1, ROUND, round=1, expected=3))
    assert checked == [[3]]
    assert heard.senders.tolist() == [0] and [sender for sender, _ in radio.rejected] == [3]


def forged(*sources):
    """An offer like :func:`offer`'s but for its vectors, [123, 456, 789]: false."""
    made = offer(*sources)
    made.vectors[:] = [123.0, 456.0, 789.0]
    return made


def vectors_checked(heard, phase):
    """A check that finds the forged vector false (code 4, as plausible.REASONS)."""
    return np.where(np.all(heard.vectors == [123.0, 456.0, 789.0], axis=1), 4, 0).astype(np.int8)


def test_an_offer_found_false_counts_for_nobody_until_the_real_sender_speaks():
    # A forgery of FLS 3's offer comes first: the round must still wait for FLS 3's own.
    radio = RadioHub({0}, check=vectors_checked)
    radio.on_control(Control(1, START, expected=3))
    assert radio.on_offer(1, 0, 3, forged(5), SWEET_VISIBLE) is None
    assert radio.on_control(Control(1, ROUND, round=0, expected=3))[1] is None
    assert radio.on_offer(1, 0, 0, offer(6), SWEET_VISIBLE) is None
    assert radio.on_offer(1, 0, 2, offer(7), SWEET_VISIBLE) is None  # 3 senders, but one forged
    assert [sender for sender, _ in radio.rejected] == [3]
    assert radio.on_offer(1, 0, 3, offer(5), SWEET_VISIBLE) == Ack(1, 0, 0, 3)
    _, _, heard = radio.on_control(Control(1, ROUND, round=1, expected=3))
    assert heard.senders.tolist() == [0, 2, 3]
    assert not (heard.vectors == 123.0).any()


def test_forgeries_that_fill_a_sender_s_slots_do_not_keep_its_real_offer_out():
    radio = RadioHub({0}, check=vectors_checked)
    radio.on_control(Control(1, START, expected=2))
    radio.on_control(Control(1, ROUND, round=0, expected=2))
    for _ in range(5):  # a flood of them, before the real one
        assert radio.on_offer(1, 0, 3, forged(5), SWEET_VISIBLE) is None
    assert radio.on_offer(1, 0, 3, offer(5), SWEET_VISIBLE) is None
    assert radio.on_offer(1, 0, 0, offer(6), SWEET_VISIBLE) == Ack(1, 0, 0, 2)
    _, _, heard = radio.on_control(Control(1, ROUND, round=1, expected=2))
    assert heard.senders.tolist() == [0, 3] and heard.source_ids.tolist() == [6, 5]
    assert not (heard.vectors == 123.0).any()


def test_offers_of_departed_flss_or_of_another_phase_count_for_nobody():
    radio = RadioHub({0}, check=vectors_checked)
    radio.on_control(Control(1, START, expected=2, departed_ids=(4,)))
    radio.on_control(Control(1, ROUND, round=0, phase=SWEET_VISIBLE, expected=2))
    assert radio.on_offer(1, 0, 4, offer(5), SWEET_VISIBLE) is None  # departed
    assert radio.on_offer(1, 0, 0, offer(6), SWEET_VISIBLE) is None
    assert radio.on_offer(1, 0, 3, offer(5), ANY_VISIBLE) is None  # says another phase
    assert radio.rejected == [(3, "an offer of another phase than its round's")]
    assert radio.on_offer(1, 0, 3, offer(5), SWEET_VISIBLE) == Ack(1, SWEET_VISIBLE, 0, 2)


def fit_block(senders, values=None, partials=None, round_=0):
    """A block of FIT offers of ``senders``: values and partials one row each."""
    count = len(senders)
    return FitBlock(
        1,
        round_,
        np.array(senders, dtype=np.int64),
        np.zeros((count, 0)) if values is None else np.asarray(values, dtype=float),
        np.zeros((count, 0)) if partials is None else np.asarray(partials, dtype=float),
    )


def fit_round(radio, round_=0, departed=()):
    radio.on_control(Control(1, START, phase=FIT, expected=5, departed_ids=departed))
    return radio.on_control(Control(1, ROUND, phase=FIT, round=round_, expected=4))


def test_a_block_of_fit_offers_is_heard_and_tallied_as_each_of_its_rows_alone():
    # FLSs 0-3 of this process offer together; 1 has departed; 7 is another process's.
    block = fit_block([0, 1, 2, 3], partials=[[1e16, 1.0], [5.0, 5.0], [1.0, 2.0], [-1e16, 3.0]])
    radios = [RadioHub({0, 1, 2, 3}), RadioHub({0, 1, 2, 3})]
    for radio in radios:
        fit_round(radio, departed=(1,))
        radio.on_offer(1, 0, 7, fit_offer(FitOffer(partials=np.array([0.5, 0.5]))))
    radios[0].sent_block(block, size=300)
    radios[1].sent_all(block.broadcasts(), [100, 100, 50, 50])
    sent = [radio.take_sent(1, 0) for radio in radios]
    assert sent[0] == sent[1]
    assert sent[0].senders == (0, 1, 2, 3) and sent[0].bytes == 300
    # Summed exactly, every row sent: 1.0 and 5.0 survive 1e16 - 1e16.
    assert sent[0].fit_sums == (6.0, 11.0)
    # Heard: the departed FLS's row is not kept, and the round is complete (0, 2, 3, 7).
    acks = [radios[0].on_block(block), radios[1].on_offers(1, 0, block.broadcasts())]
    assert acks[0] == acks[1] == Ack(1, FIT, 0, 4)
    tables = [radio.on_control(Control(1, ROUND, phase=FIT, round=1))[2] for radio in radios]
    assert tables[0].senders.tolist() == tables[1].senders.tolist() == [0, 2, 3, 7]


def test_a_round_table_joins_blocks_of_fit_offers_with_the_offers_heard_by_sender():
    heard = [
        (5, fit_offer(FitOffer(label=2, values=np.array([5.0, 5.5])))),
        (2, offer(1, 3)),
    ]
    blocks = [fit_block([1, 6], values=[[1.0, 1.5], [6.0, 6.5]]), fit_block([3], [[3.0, 3.5]])]
    table = RoundOffers.of(heard, blocks)
    rows = [(sender, fit_offer(block.said(row))) for block in blocks
            for row, sender in enumerate(block.senders.tolist())]  # fmt: skip
    alone = RoundOffers.of(heard + rows)
    assert table.senders.tolist() == [1, 2, 3, 5, 6]
    for name in ("senders", "starts", "source_ids", "path_offsets", "fit_labels",
                 "fit_offsets", "fit_values"):  # fmt: skip
        np.testing.assert_array_equal(getattr(table, name), getattr(alone, name), err_msg=name)
    labels, _, values = table.fit_of(np.array([3, 5, 6]))
    assert labels.tolist() == [-1, 2, -1] and values.tolist() == [3.0, 3.5, 5.0, 5.5, 6.0, 6.5]
    assert table.labels_of(np.array([1, 2, 3])).tolist() == [0, 1]
    # One block alone, a process's own: its values are read in place.
    own = RoundOffers.of([], blocks[:1])
    assert np.shares_memory(own.fit_values, blocks[0].values)
