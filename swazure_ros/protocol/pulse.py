"""A process's own progress, from its executor's regular looks (docs/protocol.md).

A process that is alive but behind (its executor busy, or the machine's
cores taken by others) looks late; one that was stopped (``kill -STOP``, a
long swap) looks late by the whole stop, having used no CPU meanwhile. A
:class:`Pulse` tells the two apart from the process's own clocks: the time
between two looks, and the CPU time the process used in between. A look
late by more than a whole period says the process is behind (its radio
tells the coordinator, which then waits longer for it); a look late by
more than a lease's silence (:meth:`Beat.stalled`) with the process nearly
idle meanwhile, and not for want of a CPU, says that it was stopped, its DDS
participant silent that long too, so that peers may have dropped it (the
process then joins again: an FLS's program starts afresh, a packed process
announces itself again). A process starved of CPU (:attr:`Beat.starved`:
its threads spent the time waiting to run, and it was not continued after a
stop) is slow, not stopped: it keeps its state, and one that was idle
meanwhile, whose DDS threads may not have announced it, announces itself
again (:meth:`Beat.starved_past`).

Times in seconds: ``now`` on any monotonic clock, ``cpu`` the process's
CPU time (``time.process_time``: every thread's, DDS's own included),
``waited`` the time the process's threads have spent runnable but waiting
for a CPU, summed (Linux's run delay, ``/proc/self/task/*/schedstat``; 0
where the system does not say). The executor's own wait is not enough: an
executor blocked on a lock that a starved DDS thread holds is asleep, not
waiting to run. ``continued``: the process was continued after a stop
(``kill -CONT``) since the last look. When a stopped process goes on, its
threads become runnable all at once, and on a loaded machine their summed
wait for a CPU can pass half of a 12 s stop (the per-FLS lease test under the
loaded suite, 2026-12-06); the stop, not the wait, made it late.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Seconds a process may go unseen before a peer can have dropped its participant:
#: a lease (Fast DDS's default 20 s, config/fastdds.xml's 5 s) less the announcement
#: period it was announced in (3 s, 1 s), for the shortest lease the project uses.
STALLED_AFTER = 4.0
#: Of the time between two looks, the share of one core a process that was stalled
#: used at most: a process stopped uses none, one starved (load 30 on 2 cores, at
#: nice 10) a few per cent; one busy in a long callback uses a whole core, and its
#: DDS threads announced it meanwhile.
IDLE_SHARE = 0.25
#: Of a late look's lateness, the share the process's threads spent runnable but waiting
#: for a CPU (summed) beyond which it was starved, not stopped. The executor's own wait,
#: measured at nice 10 beside 60 busy loops on 2 cores, on the EventsExecutor
#: (2026-11-29): looks 52.1 s, 3.8 s and 1.3 s late had waited 49.4 s, 4.8 s and 2.2 s
#: (the wait also counts the look's own period); every thread's sum is no less. One
#: 9.8 s late after a 10 s ``kill -STOP`` had waited 0.0 s: a stopped thread waits for
#: nothing, so every thread's sum stays as small.
STARVED_SHARE = 0.5


@dataclass(frozen=True)
class Beat:
    """What one look of a :class:`Pulse` found."""

    late: float  # s the look came later than its period (0 within the tolerance)
    idle: bool  # the process used at most IDLE_SHARE of a core meanwhile
    # Its threads waited for a CPU for half the lateness or more, and it was not stopped.
    starved: bool = False

    @property
    def behind(self) -> bool:
        """Late by more than nothing: the executor did not look when it was due."""
        return self.late > 0.0

    def stalled(self, after: float = STALLED_AFTER) -> bool:
        """Late by more than ``after`` s with the process nearly idle and not starved: stopped
        (``kill -STOP``, the machine paused), its DDS threads too, for long enough that a
        peer with a lease of ``after`` s plus one announcement period may have dropped it."""
        return self.idle and not self.starved and self.late > after

    def starved_past(self, after: float = STALLED_AFTER) -> bool:
        """Late by more than ``after`` s with the process nearly idle for want of a CPU: slow,
        not stopped, but its DDS threads may have been kept from announcing it as long, so
        a peer may have dropped it. A busy process (more than IDLE_SHARE of a core) is not:
        its threads had their turns, DDS's among them. Under load its threads' summed wait
        passes half its lateness at many a late look, and a packed process that announced
        itself again at each would republish its thousands of nodes to every peer."""
        return self.idle and self.starved and self.late > after


class Pulse:
    """The regular looks of a process's executor, every ``period`` s from ``now``.

    ``late`` of a :class:`Beat` counts only what exceeds ``tolerance`` s: a
    look a little late (a busy moment) is on time.
    """

    def __init__(
        self, period: float, now: float, cpu: float, tolerance: float = 0.0, waited: float = 0.0
    ) -> None:
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"period must be a positive number of seconds, got {period}")
        if not (math.isfinite(tolerance) and tolerance >= 0.0):
            raise ValueError(f"tolerance must be a number of seconds >= 0, got {tolerance}")
        self.period = period
        self.tolerance = tolerance
        self._now = now
        self._cpu = cpu
        self._waited = waited

    def look(self, now: float, cpu: float, waited: float = 0.0, continued: bool = False) -> Beat:
        """A look at monotonic time ``now`` with the process's CPU time ``cpu``, its
        threads' wait for a CPU ``waited`` and whether it was ``continued`` after a stop
        since the last look: how late it is, and why."""
        since = now - self._now
        used = cpu - self._cpu
        queued = waited - self._waited
        self._now, self._cpu, self._waited = now, cpu, waited
        late = since - self.period
        late = late if late > self.tolerance else 0.0
        starved = late > 0.0 and not continued and queued >= STARVED_SHARE * late
        return Beat(late, used < IDLE_SHARE * since, starved)


@dataclass(frozen=True)
class Alive:
    """A process's radio says it is alive (a Heartbeat message): what it hears, how late it is."""

    host: str  # the radio's node name
    hears_controls: bool  # its reader of the coordinator's controls is matched
    run_id: int  # the newest run it has a control of (0: none yet)
    round: int  # that control's round
    late: float  # s its executor looked late; 0: on time
