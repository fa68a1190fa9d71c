"""Many nodes' periodic timers on one timer of one node.

rclpy's EventsExecutor keeps a thread for each clock that has a timer, and
every node has a clock of its own: a packed process of 16,384 FLS nodes, each
with its frame timer, ran out of threads in its bring-up ("can't start new
thread"; docs/swarm.md). Putting the timers on one shared clock instead makes
the executor go over every timer of that clock at each timer's reset, and
print a warning for each timer past a handful. So a process's FLS nodes take
their frames from :class:`SharedTimers`: one rclpy timer of the host's node,
ticking while any of them runs, calls each when it is due.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

from rclpy.clock import Clock
from rclpy.clock_type import ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.node import Node
from rclpy.timer import Timer

#: How often the shared timer looks for due timers while one runs, s: a frame is at most
#: this late (a frame period is 0.1 s or more).
TICK = 0.01


class SharedTimer:
    """One periodic timer of :class:`SharedTimers`: the part of ``rclpy.timer.Timer`` that a
    node's frames use (``reset``, ``cancel``, ``timer_period_ns``)."""

    def __init__(self, owner: SharedTimers, period_ns: int, callback: Callable[[], None]) -> None:
        self._owner = owner
        self.timer_period_ns = period_ns
        self.callback = callback
        self.due_ns = 0  # on the shared node's clock; meaningful while it runs

    def reset(self) -> None:
        """Run again, the first call a period from now (as rclpy's ``Timer.reset``)."""
        self._owner.start(self)

    def cancel(self) -> None:
        """Stop until :meth:`reset`."""
        self._owner.stop(self)

    def is_canceled(self) -> bool:
        """Whether it is stopped."""
        return not self._owner.runs(self)


class SharedTimers:
    """Periodic timers on one timer of ``node``, which ticks only while one of them runs."""

    def __init__(self, node: Node, tick: float = TICK) -> None:
        self._node = node
        self._running: dict[int, SharedTimer] = {}
        # The earliest a running timer is due, or earlier: a tick before it looks at none.
        self._next_due = 0
        # On a clock of its own: started and stopped often, on the node's clock it held
        # back the node's other timers (its host's heartbeats came seconds late).
        self._ticks: Timer = node.create_timer(
            tick, self._on_tick, clock=Clock(clock_type=ClockType.STEADY_TIME)
        )
        self._ticks.cancel()

    def create_timer(self, period: float, callback: Callable[[], None]) -> SharedTimer:
        """A timer that calls ``callback`` every ``period`` s, running from now."""
        timer = SharedTimer(self, round(period * 1e9), callback)
        self.start(timer)
        return timer

    def start(self, timer: SharedTimer) -> None:
        """Run ``timer``, its first call a period from now."""
        timer.due_ns = self._now() + timer.timer_period_ns
        if not self._running:
            self._ticks.reset()
            self._next_due = timer.due_ns
        self._next_due = min(self._next_due, timer.due_ns)
        self._running[id(timer)] = timer

    def stop(self, timer: SharedTimer) -> None:
        """Stop ``timer``; the shared timer too once none runs."""
        self._running.pop(id(timer), None)
        if not self._running:
            # Its node may be gone already (a process closing): then nothing ticks.
            with contextlib.suppress(InvalidHandle):
                self._ticks.cancel()

    def runs(self, timer: SharedTimer) -> bool:
        """Whether ``timer`` runs."""
        return id(timer) in self._running

    @property
    def running(self) -> int:
        """How many timers run."""
        return len(self._running)

    def _now(self) -> int:
        return int(self._node.get_clock().now().nanoseconds)

    def _on_tick(self) -> None:
        now = self._now()
        if now < self._next_due:  # most ticks: thousands of FLSs' frames run, none is due
            return
        for timer in list(self._running.values()):
            if timer.due_ns > now or not self.runs(timer):
                continue
            # The next call a whole number of periods on, as rclpy's timers keep their phase.
            periods = (now - timer.due_ns) // max(timer.timer_period_ns, 1) + 1
            timer.due_ns += periods * timer.timer_period_ns
            timer.callback()
        self._next_due = min((timer.due_ns for timer in self._running.values()), default=0)
