"""The coordinator's runs: they wait their turn in order, one runs, each with its own run id."""

from __future__ import annotations

import time

from swazure_ros.core.paths import FEWEST_HOPS
from swazure_ros.protocol.rounds import RoundClock
from swazure_ros.protocol.run_queue import RunQueue
from swazure_ros.protocol.runs import Traffic

FLSS = (0, 1, 2)


def clock(run_id: int) -> RoundClock:
    return RoundClock(run_id, FEWEST_HOPS, FLSS, 1, 10.0)


def test_runs_begin_in_the_order_asked_one_at_a_time_with_consecutive_run_ids():
    runs: RunQueue[str] = RunQueue()
    assert runs.next_waited() is None and runs.running() is None
    runs.add(clock, "first")
    runs.add(clock, "second")
    waited = runs.next_waited()
    assert waited is not None and waited >= 0.0
    first = runs.begin_next(Traffic())
    assert runs.running() is first
    # While one runs, none is to start.
    assert runs.next_waited() is None
    job = runs.finish()
    assert (job.future, job.machine) == ("first", first)
    assert runs.running() is None and runs.next_waited() is not None
    second = runs.begin_next(Traffic())
    assert runs.finish().future == "second"
    assert second.run_id == first.run_id + 1
    assert runs.next_waited() is None


def test_only_the_running_run_is_found_by_its_id():
    runs: RunQueue[None] = RunQueue()
    runs.add(clock, None)
    machine = runs.begin_next(Traffic())
    assert runs.running(machine.run_id) is machine
    # A message of another run (one over, or a coordinator's before a restart) finds none.
    assert runs.running(machine.run_id - 1) is None
    assert runs.running(machine.run_id + 1) is None


def wall_clock_run_id() -> int:
    """A run id from the wall clock now: milliseconds, in uint32 (as RunQueue takes it)."""
    return time.time_ns() // 1_000_000 % 2**31 + 1


def test_run_ids_start_from_the_wall_clock_so_a_restarted_coordinator_takes_new_ones():
    # A coordinator started later begins above the run ids of one before it: the
    # leftovers of the earlier one's runs are never taken for the new one's.
    before = wall_clock_run_id()
    runs: RunQueue[None] = RunQueue()
    after = wall_clock_run_id()
    runs.add(clock, None)
    run_id = runs.begin_next(Traffic()).run_id
    assert 0 < run_id < 2**31
    assert before <= run_id <= after or after < before  # (or the count wrapped meanwhile)


def test_a_run_keeps_the_traffic_as_it_began_not_what_came_after():
    runs: RunQueue[None] = RunQueue()
    traffic = Traffic()
    traffic.count("discovery", 100)
    runs.add(clock, None)
    runs.begin_next(traffic)
    traffic.count("discovery", 50)
    job = runs.finish()
    assert job.traffic.bytes == {"discovery": 100}
    assert traffic.since(job.traffic).bytes == {"discovery": 50}
