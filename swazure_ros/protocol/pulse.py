"""A process's own progress, from its executor's regular looks (docs/protocol.md).

A process that is alive but behind (its executor busy, or the machine's
cores taken by others) looks late; one that was stopped (``kill -STOP``, a
long swap) looks late by the whole stop, having used no CPU meanwhile. A
:class:`Pulse` tells the two apart from the process's own clocks: the time
between two looks, and the CPU time the process used in between. A look
late by more than a whole period says the process is behind (its radio
tells the coordinator, which then waits longer for it); a look late by
more than a lease's silence (:meth:`Beat.stalled`) with the process nearly
idle meanwhile says that its DDS participant was silent that long too, so
that peers may have dropped it (the process then joins again: an FLS's
program starts afresh, a packed process announces itself again).

Times in seconds: ``now`` on any monotonic clock, ``cpu`` the process's
CPU time (``time.process_time``: every thread's, DDS's own included).
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


@dataclass(frozen=True)
class Beat:
    """What one look of a :class:`Pulse` found."""

    late: float  # s the look came later than its period (0 within the tolerance)
    idle: bool  # the process used at most IDLE_SHARE of a core meanwhile

    @property
    def behind(self) -> bool:
        """Late by more than nothing: the executor did not look when it was due."""
        return self.late > 0.0

    def stalled(self, after: float = STALLED_AFTER) -> bool:
        """Late by more than ``after`` s with the process nearly idle: stopped or starved, its
        DDS threads too, for long enough that a peer with a lease of ``after`` s plus one
        announcement period may have dropped it."""
        return self.idle and self.late > after


class Pulse:
    """The regular looks of a process's executor, every ``period`` s from ``now``.

    ``late`` of a :class:`Beat` counts only what exceeds ``tolerance`` s: a
    look a little late (a busy moment) is on time.
    """

    def __init__(self, period: float, now: float, cpu: float, tolerance: float = 0.0) -> None:
        if not (math.isfinite(period) and period > 0.0):
            raise ValueError(f"period must be a positive number of seconds, got {period}")
        if not (math.isfinite(tolerance) and tolerance >= 0.0):
            raise ValueError(f"tolerance must be a number of seconds >= 0, got {tolerance}")
        self.period = period
        self.tolerance = tolerance
        self._now = now
        self._cpu = cpu

    def look(self, now: float, cpu: float) -> Beat:
        """A look at monotonic time ``now`` with the process's CPU time ``cpu``: how late it is."""
        since = now - self._now
        used = cpu - self._cpu
        self._now, self._cpu = now, cpu
        late = since - self.period
        return Beat(late if late > self.tolerance else 0.0, used < IDLE_SHARE * since)


@dataclass(frozen=True)
class Alive:
    """A process's radio says it is alive (a Heartbeat message): what it hears, how late it is."""

    host: str  # the radio's node name
    hears_controls: bool  # its reader of the coordinator's controls is matched
    run_id: int  # the newest run it has a control of (0: none yet)
    round: int  # that control's round
    late: float  # s its executor looked late; 0: on time
