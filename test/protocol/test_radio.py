"""One process's radio: who hears a broadcast, and when a round is acknowledged."""

from __future__ import annotations

import numpy as np

from swazure_ros.protocol.discovery import END, ROUND, START, Control
from swazure_ros.protocol.radio import Ack, RadioHub

# FLSs 0 and 1 live here, 2 and 3 in another process; 0 hears 1 and 2, 3 hears only 2.
RANGE = {0: [1, 2], 1: [0], 2: [0, 3], 3: [2]}


def hub():
    return RadioHub({0, 1}, lambda fls: np.array(RANGE[fls], dtype=np.int64))


def test_a_broadcast_reaches_the_local_flss_in_radio_range_only():
    radio = hub()
    radio.on_control(Control(1, START, expected=4))
    assert radio.on_offer(1, 0, 2)[0] == [0]  # 3 is in range of 2 but not local
    assert radio.on_offer(1, 0, 0)[0] == [1]
    assert radio.on_offer(1, 0, 3)[0] == []


def test_a_round_is_acknowledged_once_every_offer_is_delivered():
    radio = hub()
    radio.on_control(Control(1, START, expected=4))
    recipients, ack = radio.on_control(Control(1, ROUND, round=0, expected=4))
    assert sorted(recipients) == [0, 1] and ack is None
    for sender in (0, 1, 2):
        assert radio.on_offer(1, 0, sender)[1] is None
    assert radio.on_offer(1, 0, 3)[1] == Ack(1, 0, 0, 4)


def test_offers_that_arrive_before_their_round_count_toward_its_ack():
    radio = hub()
    radio.on_control(Control(1, START, expected=2))
    radio.on_offer(1, 0, 2)
    radio.on_offer(1, 0, 3)
    _, ack = radio.on_control(Control(1, ROUND, round=0, expected=2))
    assert ack == Ack(1, 0, 0, 2)


def test_departed_flss_neither_hear_nor_are_heard_and_stale_rounds_are_ignored():
    radio = hub()
    radio.on_control(Control(1, START, round=0, expected=4))
    recipients, _ = radio.on_control(Control(1, START, round=3, expected=3, departed_ids=(1,)))
    assert recipients == [0]
    assert radio.on_offer(1, 3, 1) == ([], None)  # from the departed FLS
    assert radio.on_offer(1, 3, 0)[0] == []  # 1 would hear it, but has departed
    assert radio.on_offer(1, 2, 2) == ([], None)  # from before the restart
    radio.on_control(Control(1, END))
    assert radio.departed(1) == frozenset()
