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
    # Stopped with the whole machine (nothing ran, nothing waited to run): stalled too.
    paused = Pulse(1.0, now=0.0, cpu=0.0, waited=2.0).look(12.0, 0.0, waited=2.0)
    assert paused.stalled() and not paused.starved
    # Stopped for less than a lease can lapse: behind only.
    short = Pulse(1.0, now=0.0, cpu=0.0).look(1.0 + STALLED_AFTER - 0.5, 0.0)
    assert short.behind and not short.stalled()
    # Under Fast DDS's default lease (20 s, announced every 3 s) only past 17 s.
    assert not beat.stalled(after=30.0) and beat.stalled(after=17.0)


def test_a_process_starved_of_cpu_is_behind_but_not_stalled():
    # At nice 10 beside 60 busy loops (pulse.STARVED_SHARE): 52 s late, 0.4 s of CPU used,
    # 49 s of it runnable and waiting for a CPU. Its DDS threads had their turns too.
    pulse = Pulse(0.5, now=0.0, cpu=0.0, waited=1.0)
    starved = pulse.look(52.6, 0.43, waited=50.4)
    assert starved.idle and starved.starved and starved.behind and not starved.stalled()
    # The same lateness with a wait of a few seconds: stopped for most of it.
    stopped = Pulse(0.5, now=0.0, cpu=0.0).look(52.6, 0.43, waited=3.0)
    assert not stopped.starved and stopped.stalled()
    # Continued after a stop (kill -CONT): its threads, runnable all at once when it went
    # on, waited 7 s of a 12 s stop on a loaded machine. The stop made it late.
    continued = Pulse(0.5, now=0.0, cpu=0.0).look(12.5, 0.1, waited=7.0, continued=True)
    assert not continued.starved and continued.stalled()
    # A look on time is never starved, however long it waited.
    assert not Pulse(0.5, now=0.0, cpu=0.0).look(0.5, 0.0, waited=0.4).starved


def test_only_a_process_idle_for_want_of_a_cpu_past_a_lease_may_have_been_dropped():
    # Idle, waiting to run for most of 52 s: peers may have dropped it.
    idle = Pulse(0.5, now=0.0, cpu=0.0).look(52.6, 0.43, waited=50.4)
    assert idle.starved_past() and not idle.starved_past(after=60.0)
    # Busy (a core's worth of CPU in 6 s) though its threads waited as long: they ran,
    # DDS's among them.
    busy = Pulse(0.5, now=0.0, cpu=0.0).look(6.5, 6.0, waited=5.0)
    assert busy.starved and not busy.idle and not busy.starved_past()
    # Stopped: not starved.
    stopped = Pulse(0.5, now=0.0, cpu=0.0).look(52.6, 0.0, waited=0.0)
    assert stopped.stalled() and not stopped.starved_past()


def test_a_pulse_refuses_periods_that_are_no_time():
    with pytest.raises(ValueError, match="period"):
        Pulse(0.0, now=0.0, cpu=0.0)
    with pytest.raises(ValueError, match="period"):
        Pulse(float("nan"), now=0.0, cpu=0.0)
    with pytest.raises(ValueError, match="tolerance"):
        Pulse(1.0, now=0.0, cpu=0.0, tolerance=-1.0)
