"""The coordinator's round clock, event by event, on a swarm of three FLSs."""

from __future__ import annotations

from swazure_ros.protocol.discovery.estimate import Estimate
from swazure_ros.protocol.discovery.messages import (
    ANY_VISIBLE,
    END,
    ROUND,
    START,
    SWEET_ALL,
    SWEET_VISIBLE,
)
from swazure_ros.protocol.radio import Sent
from swazure_ros.protocol.rounds import RoundClock

FLSS = (0, 1, 2)
TIMEOUT = 10.0


def clock(**options):
    return RoundClock(7, "fewest-hops", FLSS, 1, TIMEOUT, **options)


def every_offer(clock_, round_, labels=0, now=0.0, senders=FLSS, finished=()):
    """Every sender broadcasts in ``round_``; the controls that come out."""
    out = []
    for sender in senders:
        ended = (sender,) if sender in finished else ()
        out += clock_.on_sent(round_, Sent((sender,), labels, (), ended), now)
    return out


def through_every_round(clock_, estimates_at=0.0):
    """The run's three rounds, each offered by every FLS and acknowledged by host_0, then
    source 0's estimates at ``estimates_at`` s: only the other sources' are left."""
    for round_ in range(3):
        every_offer(clock_, round_)
        clock_.on_ack(round_, "host_0", 0.0)
    clock_.on_estimates(0, [], estimates_at)


def test_a_run_starts_each_phase_opens_rounds_and_ends_with_the_estimates():
    run = clock()
    start, first = run.start(0.0)
    assert (start.command, start.phase, start.round) == (START, SWEET_VISIBLE, 0)
    assert (first.command, first.round, first.expected) == (ROUND, 0, 3)
    # Labels were sent: the phase goes on. The round closes only with the process's ack.
    assert every_offer(run, 0, labels=2) == []
    (second,) = run.on_ack(0, "host_0", 0.0)
    assert (second.command, second.phase, second.round) == (ROUND, SWEET_VISIBLE, 1)
    # A quiet round ends the phase: the next starts, its first round at the next number.
    every_offer(run, 1)
    start, first = run.on_ack(1, "host_0", 0.0)
    assert (start.command, start.phase, start.round, first.round) == (START, SWEET_ALL, 2, 2)
    every_offer(run, 2)
    start, _ = run.on_ack(2, "host_0", 0.0)
    assert (start.command, start.phase) == (START, ANY_VISIBLE)
    every_offer(run, 3)
    (end,) = run.on_ack(3, "host_0", 0.0)
    assert end.command == END and not run.done
    for source in FLSS:
        run.on_estimates(source, [Estimate(target=9, status=0, reason=0)], 0.0)
    assert run.done
    assert run.outcome.rounds == 4 and run.outcome.restarts == 0
    assert sorted(run.outcome.estimates) == list(FLSS)


def test_finished_sources_are_named_in_the_next_round_once():
    run = clock()
    run.start(0.0)
    every_offer(run, 0, labels=1, finished=(1,))
    (second,) = run.on_ack(0, "host_0", 0.0)
    assert second.finished_ids == (1,)
    every_offer(run, 1, labels=1, finished=(1,))
    (third,) = run.on_ack(1, "host_0", 0.0)
    assert third.finished_ids == ()


def test_a_pass_that_cut_searches_short_is_followed_by_one_reaching_farther():
    # Round 0: every FLS searches, FLS 1 finishes; round 1: FLSs 0 and 2 hold labels of
    # source 2 beyond the reach. The quiet round after starts the same phase's next pass:
    # of the three searches only source 0's ran to its end (2 was cut short, 1 closed early).
    # A pass that cuts nothing short ends the phase.
    run = clock()
    start, _ = run.start(0.0)
    assert (start.reach_pass, start.exhausted_ids) == (0, ())
    run.on_sent(0, Sent(FLSS, 3, (), (1,), searching=FLSS), 0.0)
    run.on_ack(0, "host_0", 0.0)
    run.on_sent(1, Sent((0, 2), 1, (), (), beyond=(2,)), 0.0)
    run.on_sent(1, Sent((1,), 0, (), ()), 0.0)
    run.on_ack(1, "host_0", 0.0)
    every_offer(run, 2)
    start, first = run.on_ack(2, "host_0", 0.0)
    assert (start.command, start.phase, start.round, first.round) == (START, SWEET_VISIBLE, 3, 3)
    assert (start.reach_pass, start.exhausted_ids) == (1, (0,))
    run.on_sent(3, Sent(FLSS, 1, (), (), searching=(2,)), 0.0)
    run.on_ack(3, "host_0", 0.0)
    every_offer(run, 4)
    start, _ = run.on_ack(4, "host_0", 0.0)
    assert (start.command, start.phase, start.reach_pass, start.exhausted_ids) == (
        START,
        SWEET_ALL,
        0,
        (),
    )


def test_a_phase_restarted_in_a_later_pass_starts_again_from_its_first():
    run = clock()
    run.start(0.0)
    run.on_sent(0, Sent(FLSS, 0, (), (), beyond=(0,)), 0.0)
    (start, _) = run.on_ack(0, "host_0", 0.0)
    assert start.reach_pass == 1
    every_offer(run, 1, labels=1)
    start, _ = run.on_ack(1, "host_0", 0.0, lost=1)  # a delivery lost for good
    assert (start.phase, start.reach_pass, start.exhausted_ids) == (SWEET_VISIBLE, 0, ())


def test_an_fls_silent_past_the_deadline_departs_and_the_phase_restarts_without_it():
    run = clock()
    run.start(0.0)
    every_offer(run, 0, senders=(0, 2), labels=1)
    run.on_ack(0, "host_0", 1.0)
    assert run.on_tick(1.0 + TIMEOUT) == []  # not past the deadline yet
    start, first = run.on_tick(1.0 + TIMEOUT + 0.1)
    assert (start.command, start.phase, start.departed_ids) == (START, SWEET_VISIBLE, (1,))
    assert (first.command, first.expected, first.departed_ids) == (ROUND, 2, (1,))
    assert run.restarts == 1 and run.warnings and "FLS [1]" in run.warnings[0]
    # The late offer of the departed FLS no longer counts.
    assert run.on_sent(start.round, Sent((1,), 5, (1,), ()), 12.0) == []


def test_a_source_that_never_reports_departs_at_the_end():
    run = clock(sources=(0, 2), targets=(2, 0))
    start, _ = run.start(0.0)
    assert start.source_ids == (0, 2) and start.target_ids == (2, 0)
    through_every_round(run)
    assert not run.done
    run.on_tick(2 * TIMEOUT)
    assert run.done and run.outcome.departed == frozenset({2})
    assert list(run.outcome.estimates) == [0]


def test_departed_flss_of_earlier_runs_take_no_part():
    run = clock(departed={1})
    start, first = run.start(0.0)
    assert start.departed_ids == (1,) and first.expected == 2
    every_offer(run, 0, senders=(0, 2))
    assert run.on_ack(0, "host_0", 0.0)[0].phase == SWEET_ALL


def test_a_stalled_process_does_not_time_its_flss_out():
    from swazure_ros.protocol.rounds import StallClock

    deadlines = StallClock(tick=0.05, stall=0.5, now=100.0)
    run = clock()

    def look(now):
        """The coordinator's tick: the deadlines are looked at unless the tick came late."""
        return run.on_tick(deadlines(now)) if deadlines.tick(now) else None

    run.start(deadlines(100.0))
    assert look(100.05) == []
    # The process was busy for 30 s (three round timeouts): the late look is skipped...
    assert look(130.05) is None
    # ...the offers that waited behind it are heard, and the round goes on.
    every_offer(run, 0, labels=1, now=deadlines(130.06))
    assert run.on_ack(0, "host_0", deadlines(130.07))[0].round == 1
    assert look(130.1) == []
    assert run.restarts == 0 and not run.departed
    # Silence the process could hear still counts: looks every tick, past the timeout.
    now = 130.1
    while not run.departed:
        now += 0.05
        look(now)
    assert run.departed == set(FLSS) and 130.1 + TIMEOUT < now < 130.1 + TIMEOUT + 0.2


def test_an_fls_known_gone_departs_at_once_and_the_phase_restarts_without_it():
    run = clock()
    run.start(0.0)
    every_offer(run, 0, senders=(0, 2), labels=1)
    # Long before the deadline: liveness says FLS 1 is gone.
    start, first = run.on_gone({1}, 0.5)
    assert (start.command, start.departed_ids) == (START, (1,))
    assert (first.command, first.expected) == (ROUND, 2)
    assert run.restarts == 1 and "FLS [1] gone" in run.warnings[-1]
    assert run.on_gone({1}, 0.6) == []  # known already
    assert run.on_gone({99}, 0.6) == []  # not in this swarm


def test_an_fls_gone_with_its_own_radio_is_no_longer_waited_for_in_any_round():
    # One process per FLS: each FLS is a radio of its own, named as its node.
    run = RoundClock(7, "fewest-hops", FLSS, 3, TIMEOUT)
    run.start(0.0)
    every_offer(run, 0, senders=(0, 2), labels=1)
    run.on_gone({1}, 0.5, radios=1)
    assert run.hosts == 2
    # The restarted phase's round closes with the two living radios' acks, at once.
    every_offer(run, 1, senders=(0, 2), labels=1)
    assert run.on_ack(1, "fls_0", 1.0) == []
    (next_round,) = run.on_ack(1, "fls_2", 1.0)
    assert (next_round.command, next_round.round) == (ROUND, 2)
    # Without the radio gone too, the same round waits for a third ack.
    stuck = RoundClock(7, "fewest-hops", FLSS, 3, TIMEOUT)
    stuck.start(0.0)
    stuck.on_gone({1}, 0.5)
    every_offer(stuck, 1, senders=(0, 2), labels=1)
    stuck.on_ack(1, "fls_0", 1.0)
    assert stuck.on_ack(1, "fls_2", 1.0) == []


def test_a_source_known_gone_at_the_end_is_not_waited_for():
    run = clock(sources=(0, 2), targets=(2, 0))
    run.start(0.0)
    through_every_round(run)
    assert not run.done
    run.on_gone({2}, 0.1)
    assert run.done and run.outcome.departed == frozenset({2})
    assert list(run.outcome.estimates) == [0]


def test_a_delivery_lost_for_good_restarts_the_phase():
    run = clock()
    run.start(0.0)
    every_offer(run, 0, labels=1)
    start, first = run.on_ack(0, "host_0", 0.0, repairs=6, lost=1)
    assert (start.command, first.command) == (START, ROUND)
    assert run.restarts == 1 and run.repairs == 6 and "lost for good" in run.warnings[-1]


def test_a_round_that_a_process_never_acknowledged_restarts_the_phase():
    # Two processes; every FLS broadcast, but process 1 never said it delivered them all.
    run = RoundClock(7, "fewest-hops", FLSS, 2, TIMEOUT)
    run.start(0.0)
    every_offer(run, 0, labels=1)
    assert run.on_ack(0, "host_0", 0.1) == []
    assert run.on_tick(0.1 + TIMEOUT / 2) == []
    start, first = run.on_tick(0.2 + TIMEOUT)
    # Not on to round 1 as if it had delivered: the phase again, with every FLS.
    assert (start.command, start.phase, start.departed_ids) == (START, SWEET_VISIBLE, ())
    assert (first.command, first.expected) == (ROUND, 3)
    assert run.restarts == 1 and not run.departed
    assert "1 process(es) silent for 10.1 s in round 0" in run.warnings[-1]


def test_a_radio_that_keeps_losing_ends_the_run_incomplete_without_estimates():
    from swazure_ros.protocol.rounds import MAX_LOSS_RESTARTS

    run = clock()
    run.start(0.0)
    for _ in range(MAX_LOSS_RESTARTS):
        every_offer(run, run.round, labels=1)
        run.on_ack(run.round, "host_0", 0.0, lost=1)
    assert not run.done
    every_offer(run, run.round, labels=1)
    (end,) = run.on_ack(run.round, "host_0", 0.0, lost=1)
    assert end.command == END
    assert run.done and run.outcome.incomplete and run.outcome.estimates == {}


def test_an_absence_counts_only_once_it_lasts_the_grace():
    from swazure_ros.protocol.rounds import Absences

    absences = Absences(2.0)
    assert absences.gone({1, 2}, 0.0) == set()
    assert absences.gone({1, 2}, 1.0) == set()
    # FLS 2 came back (a lapsed lease, re-announced): its absence starts again.
    assert absences.gone({1}, 1.5) == set()
    assert absences.gone({1, 2}, 2.0) == {1}
    assert absences.gone({2}, 3.9) == set()
    assert absences.gone({2}, 4.0) == {2}


def test_the_deadlines_follow_the_swarms_measured_round_times():
    from swazure_ros.protocol.rounds import PATIENCE, RoundTimes

    times = RoundTimes()
    assert times.deadline(TIMEOUT) == TIMEOUT  # nothing measured: the round timeout
    # Quick rounds keep the floor; a loaded machine's slow ones stretch it.
    fast = clock()
    fast.times = times
    fast.start(0.0)
    every_offer(fast, 0, labels=1, now=0.1)
    fast.on_ack(0, "host_0", 0.15)
    assert times.slow == 0.15 and fast.patience == TIMEOUT
    slow = clock()
    slow.times = times
    slow.start(0.0)
    every_offer(slow, 0, labels=1, now=2.0)
    slow.on_ack(0, "host_0", 2.5)  # a round of 2.5 s: the next run waits 25 s
    assert slow.patience == PATIENCE * 2.5
    every_offer(slow, 1, senders=(0, 2), now=3.0)
    assert slow.on_tick(3.0 + TIMEOUT + 1.0) == []  # past the round timeout: not silent yet
    start, _ = slow.on_tick(3.0 + PATIENCE * 2.5 + 0.1)
    assert start.departed_ids == (1,)
    # A round that timed out is no measure of how long rounds take.
    assert times.slow == 2.5


def test_round_times_keep_the_last_rounds_and_refuse_what_is_no_time():
    import pytest

    from swazure_ros.protocol.rounds import MOST_PATIENCE, RoundTimes

    times = RoundTimes(kept=2, patience=4.0)
    for took in (3.0, float("nan"), -1.0, float("inf"), 0.5, 0.25):
        times.add(took)
    assert times.slow == 0.5 and times.deadline(1.0) == 2.0
    # The slow end, not the slowest: one round held up for 30 s moves no deadline.
    many = RoundTimes(patience=10.0)
    for took in [0.2] * 20 + [30.0]:
        many.add(took)
    assert many.deadline(1.0) == 2.0
    # Rounds all held up make the deadlines longer, up to MOST_PATIENCE round timeouts.
    for took in [30.0] * 20:
        many.add(took)
    assert many.deadline(1.0) == MOST_PATIENCE * 1.0
    with pytest.raises(ValueError, match="kept"):
        RoundTimes(kept=0)
    with pytest.raises(ValueError, match="patience"):
        RoundTimes(patience=float("nan"))


def test_a_process_alive_but_behind_is_given_more_time_not_departed():
    from swazure_ros.protocol.rounds import MAX_STRETCH

    run = RoundClock(7, "fewest-hops", FLSS, 3, TIMEOUT)
    run.start(0.0)
    every_offer(run, 0, senders=(0, 2), labels=1, now=1.0)
    run.on_ack(0, "fls_0", 1.0)
    run.on_ack(0, "fls_2", 1.0)
    # FLS 1's process says it is behind, twice: each time the round waits on.
    assert run.on_alive("fls_1", (1,), 9.0) == []
    assert run.on_tick(1.0 + TIMEOUT + 1.0) == []
    run.on_alive("fls_1", (1,), 18.0)
    assert run.on_tick(27.0) == []
    # It answers: the round closes as ever, no FLS departed.
    every_offer(run, 0, senders=(1,), labels=1, now=27.5)
    (next_round,) = run.on_ack(0, "fls_1", 27.5)
    assert next_round.round == 1 and not run.departed and run.restarts == 0
    assert "fls_1 is behind, alive" in run.warnings[-1]
    # One that says so and never answers is held MAX_STRETCH deadlines, no longer.
    held = RoundClock(8, "fewest-hops", FLSS, 3, TIMEOUT)
    held.start(0.0)
    every_offer(held, 0, senders=(0, 2), labels=1, now=1.0)
    now = 1.0
    while not held.departed:
        now += 0.5
        held.on_alive("fls_1", (1,), now)
        held.on_tick(now)
    assert held.departed == {1}
    assert 1.0 + MAX_STRETCH * TIMEOUT <= now <= 1.5 + MAX_STRETCH * TIMEOUT


def test_a_process_behind_in_many_waits_is_named_once_and_counted_at_the_end():
    # One process of a large shape is behind in every round it works long in: the
    # coordinator says so the first time, and how often at the run's end.
    run = clock(sources=(0,), targets=(2,))
    run.start(0.0)
    for round_ in range(3):
        every_offer(run, round_, now=round_)
        run.on_alive("host_0", FLSS, round_ + 0.5)
        run.on_alive("host_0", FLSS, round_ + 0.6)  # the same wait: counted once
        run.on_ack(round_, "host_0", round_ + 0.7)
    run.on_estimates(0, [], 3.0)
    assert run.done
    behind = [warning for warning in run.outcome.warnings if "behind" in warning]
    assert len(behind) == 2
    assert "host_0 is behind, alive: round 0 waits" in behind[0]
    assert behind[1] == "run 7: host_0 was behind, alive, in 3 waits, each given more time"


def test_a_process_the_wait_does_not_wait_on_changes_no_deadline():
    run = RoundClock(7, "fewest-hops", FLSS, 2, TIMEOUT)
    run.start(0.0)
    every_offer(run, 0, senders=(0, 1), labels=1, now=1.0)
    run.on_ack(0, "host_0", 1.0)
    # host_0 acknowledged and its FLSs spoke: its word holds no one's deadline.
    run.on_alive("host_0", (0, 1), 9.0)
    start, _ = run.on_tick(1.0 + TIMEOUT + 0.1)
    assert start.departed_ids == (2,)
    # A run that is over takes no word at all.
    over = clock(sources=(0,), targets=(2,))
    over.start(0.0)
    through_every_round(over, estimates_at=0.1)
    assert over.done and over.on_alive("host_0", FLSS, 0.2) == []


def test_a_source_behind_at_the_end_is_waited_for_a_while():
    run = clock(sources=(0, 2), targets=(2, 0))
    run.start(0.0)
    through_every_round(run)
    run.on_alive("fls_2", (2,), 8.0)
    run.on_tick(TIMEOUT + 1.0)
    assert not run.done
    run.on_estimates(2, [], 12.0)
    assert run.done and not run.outcome.departed


def test_a_departed_flss_own_radio_behind_holds_no_round():
    # Three FLSs, each its own radio; FLS 1 departed in an earlier run, its radio gone.
    run = RoundClock(7, "fewest-hops", FLSS, 2, TIMEOUT, departed={1})
    run.start(0.0)
    every_offer(run, 0, senders=(0, 2), labels=1, now=1.0)
    run.on_ack(0, "fls_0", 1.0)
    # FLS 1's process goes on after a long stop and says it was behind: nobody waits for it.
    run.on_alive("fls_1", (1,), 9.0)
    assert not run.warnings
    run.on_tick(1.0 + TIMEOUT + 0.1)
    assert run.restarts == 1 and "1 process(es) silent" in run.warnings[-1]
