"""The runs asked of a swarm's coordinator: they wait their turn, in order, and one runs.

A run is a discovery's :class:`~.rounds.RoundClock` or a heuristic's
:class:`~.moves.MoveRun` (a :data:`Machine`), started when its turn comes
with a run id of its own. Whoever asked for it waits on a future the queue
keeps for it (the coordinator's rclpy ``Future``: the queue does not look
inside it).
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Generic, TypeVar

from .moves import MoveRun
from .rounds import RoundClock
from .runs import Traffic

#: The state machine of a run: a discovery's round clock, or a heuristic's moves.
Machine = RoundClock | MoveRun
#: What waits for a run's result.
Waiter = TypeVar("Waiter")


@dataclass
class Job(Generic[Waiter]):
    """A run waiting for its turn, then running: how to start it and who waits for it."""

    begin: Callable[[int], Machine]  # run id -> the run's machine
    future: Waiter
    queued: float = field(default_factory=time.monotonic)  # monotonic s
    machine: Machine | None = None
    began: float = 0.0  # time.perf_counter s, as it began
    traffic: Traffic = field(default_factory=Traffic)  # the coordinator's, as it began


class RunQueue(Generic[Waiter]):
    """The runs asked of the coordinator: they wait their turn, in order, and one runs."""

    def __init__(self) -> None:
        self._waiting: deque[Job[Waiter]] = deque()
        self.job: Job[Waiter] | None = None  # the running one
        # Run ids differ from a coordinator that ran before this one (a restart): its
        # runs' leftovers can never be taken for ours. Milliseconds, in uint32.
        self._next_run = (time.time_ns() // 1_000_000) % 2**31 + 1

    def add(self, begin: Callable[[int], Machine], future: Waiter) -> None:
        """Queue a run that ``begin(run_id)`` starts; its result goes to ``future``."""
        self._waiting.append(Job(begin, future))

    def next_waited(self) -> float | None:
        """Seconds the next run has waited while none runs; None: none is to start."""
        if self.job is not None or not self._waiting:
            return None
        return time.monotonic() - self._waiting[0].queued

    def begin_next(self, traffic: Traffic) -> Machine:
        """Start the next run (with ``traffic`` as it is now); its machine."""
        job = self._waiting.popleft()
        job.machine = job.begin(self._next_run)
        self._next_run += 1
        job.began, job.traffic = time.perf_counter(), traffic.copy()
        self.job = job
        return job.machine

    def running(self, run_id: int | None = None) -> Machine | None:
        """The running machine (of run ``run_id``, if given)."""
        machine = self.job.machine if self.job is not None else None
        if machine is None or (run_id is not None and machine.run_id != run_id):
            return None
        return machine

    def finish(self) -> Job[Waiter]:
        """The running run, done: none runs now."""
        job = self.job
        assert job is not None
        self.job = None
        return job
