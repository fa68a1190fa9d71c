"""A process's own progress from its executor's looks: on time, behind, or stalled."""

from __future__ import annotations

import pytest

from swazure_ros.protocol.pulse import STALLED_AFTER, Pulse


def test_a_look_on_time_is_neither_behind_nor_stalled():
    pulse = Pulse(1.0, now=0.0, cpu=0.0, tolerance=0.25)
    beat = pulse.look(1.0, 0.01)
    assert (beat.late, beat.behind, beat.stalled()) == (0.0, False, False)
    # A little late is on time: within the tolerance.
    assert not pulse.look(2.2, 0.02).behind


def test_a_busy_process_is_behind_but_not_stalled():
    # One long callback: 9 s late, a whole core busy meanwhile (DDS's threads ran too).
    pulse = Pulse(1.0, now=0.0, cpu=0.0)
    beat = pulse.look(10.0, 9.5)
    assert beat.behind and beat.late == pytest.approx(9.0) and not beat.stalled()


def test_a_process_stopped_past_a_lease_is_stalled():
    pulse = Pulse(1.0, now=100.0, cpu=3.0)
    beat = pulse.look(100.0 + 1.0 + STALLED_AFTER + 20.0, 3.0)  # kill -STOP for 25 s
    assert beat.behind and beat.stalled()
    # Starved, not stopped: a few per cent of a core is idle all the same.
    starved = Pulse(1.0, now=0.0, cpu=0.0).look(12.0, 0.4)
    assert starved.stalled()
    # Stopped for less than a lease can lapse: behind only.
    short = Pulse(1.0, now=0.0, cpu=0.0).look(1.0 + STALLED_AFTER - 0.5, 0.0)
    assert short.behind and not short.stalled()
    # Under Fast DDS's default lease (20 s, announced every 3 s) only past 17 s.
    assert not beat.stalled(after=30.0) and beat.stalled(after=17.0)


def test_a_pulse_refuses_periods_that_are_no_time():
    with pytest.raises(ValueError, match="period"):
        Pulse(0.0, now=0.0, cpu=0.0)
    with pytest.raises(ValueError, match="period"):
        Pulse(float("nan"), now=0.0, cpu=0.0)
    with pytest.raises(ValueError, match="tolerance"):
        Pulse(1.0, now=0.0, cpu=0.0, tolerance=-1.0)
