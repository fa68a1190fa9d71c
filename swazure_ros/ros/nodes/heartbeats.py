"""A process's radio says it is alive: its heartbeats (docs/protocol.md, "Slow is not dead").

The coordinator hears a radio through its acknowledgements while rounds run.
What it cannot hear is a radio that is alive but behind, or one that has not
matched its controls yet: both look silent. :class:`Heartbeats` says so, from
the process's own executor (a callback that a stopped or deadlocked
executor never runs), on ``heartbeats`` (swazure_interfaces/Heartbeat).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from rclpy.node import Node
from swazure_interfaces.msg import Heartbeat

from ...protocol.pulse import STALLED_AFTER, Alive, Pulse
from ..convert.discovery import heartbeat_message
from ..plumbing.names import HEARTBEAT_QOS, HEARTBEAT_TOPIC
from ..security.auth import SwarmKey

#: Seconds between two looks of a radio's executor at its own progress. A process at rest
#: spends a few tens of microseconds a look; the first beat of a radio that hears the
#: controls waits for the next look, and the swarm's bring-up with it.
PULSE_PERIOD = 0.5
#: Seconds a look may come late and still be on time: a whole second behind is news.
BEHIND_AFTER = 1.0
#: The process's threads, each with its scheduler statistics (``schedstat``: time on a
#: CPU, time waiting for one (ns), slices).
TASKS = "/proc/self/task"


def waited_for_cpu() -> float:
    """Seconds this process's threads have spent runnable but waiting for a CPU, summed
    over the threads it has now (Linux's run delay, ``/proc/self/task/*/schedstat``); 0.0
    where the system does not say.

    A starved thread's wait grows with the time it is kept from running; a
    stopped one's (``kill -STOP``) and a sleeping one's does not. Every thread
    counts, not only the caller's: an executor blocked on a lock that a
    starved DDS thread holds sleeps, and only that thread's wait says the
    process was kept from a CPU (FLS processes at load 341 stood still with
    their CPU idle and their executor's own wait small, and were taken for
    stopped). A thread that ends takes its wait with it, so the sum can fall
    between two looks.
    """
    waited = 0
    try:
        threads = os.listdir(TASKS)
    except OSError:
        return 0.0
    # os.open and os.read: half the time of open(), every look at every thread of the process.
    for thread in threads:
        try:
            schedstat = os.open(f"{TASKS}/{thread}/schedstat", os.O_RDONLY)
        except OSError:
            continue  # the thread ended meanwhile, or no statistics kept
        try:
            waited += int(os.read(schedstat, 128).split()[1])
        except (OSError, IndexError, ValueError):
            pass
        finally:
            os.close(schedstat)
    return waited / 1e9


class Heartbeats:
    """The heartbeats of one process's radio, beaten by its executor's regular looks.

    A beat goes out when the radio's reader of the coordinator's controls
    matches or unmatches (``hears``: a run can count on it from then on),
    when a look comes more than :data:`BEHIND_AFTER` late (the executor is
    behind: busy, starved of CPU or stopped; the coordinator waits longer for
    it), and after a stall long enough for peers to have dropped this
    process's participant, when the process joins again (:meth:`announce_again`,
    or what :meth:`when_stalled` says). A healthy process in a quiet swarm
    sends none. ``newest()``: the (run, round) of the newest
    control the radio has, which each beat says.
    """

    def __init__(
        self,
        node: Node,
        key: SwarmKey,
        hears: Callable[[], bool],
        newest: Callable[[], tuple[int, int]],
    ) -> None:
        self._node = node
        self._key = key
        self._hears = hears
        self._newest = newest
        self._writer = node.create_publisher(Heartbeat, HEARTBEAT_TOPIC, HEARTBEAT_QOS)
        self._pulse = Pulse(
            PULSE_PERIOD,
            time.monotonic(),
            time.process_time(),
            tolerance=BEHIND_AFTER,
            waited=waited_for_cpu(),
        )
        self.hears_controls = False  # as the last beat said
        self.beats = 0  # heartbeats sent
        self.announced_again = 0  # times the process announced itself again after a stall
        self._stall_after = STALLED_AFTER
        self._on_stall: Callable[[float], None] = self.announce_again
        self._went_on: Callable[[], bool] | None = None
        node.create_timer(PULSE_PERIOD, self.look)

    def when_stalled(
        self,
        after: float,
        act: Callable[[float], None],
        went_on: Callable[[], bool] | None = None,
    ) -> None:
        """After a stop of more than ``after`` s (late, the CPU idle, not starved),
        ``act(late)`` instead of :meth:`announce_again` (an FLS's program starts afresh past
        its lease). ``went_on()``: whether the process went on after a stop since it was
        last asked (``plumbing.process.catch_continues``, in a process whose main thread
        makes the looks); a look that finds it did is not taken for starving, however long
        its threads then waited for a CPU."""
        self._stall_after = after
        self._on_stall = act
        self._went_on = went_on

    def look(self) -> None:
        """The executor's regular look: beat if there is news."""
        went_on = self._went_on is not None and self._went_on()
        beat = self._pulse.look(time.monotonic(), time.process_time(), waited_for_cpu(), went_on)
        stalled = beat.stalled(self._stall_after)
        if stalled:
            self._on_stall(beat.late)
        elif beat.starved_past(self._stall_after):
            # Slow, not stopped: should a peer have dropped it, a new writer shows its
            # nodes again; starting afresh would lose its state.
            self.announce_again(beat.late, starved=True)
        hears = self._hears()
        if hears != self.hears_controls or beat.behind or stalled:
            self.hears_controls = hears
            self.beat(beat.late)

    def beat(self, late: float = 0.0) -> None:
        """Say that this radio is alive, what it hears, and how ``late`` its executor looked."""
        run_id, round_ = self._newest()
        alive = Alive(self._node.get_name(), self.hears_controls, run_id, round_, late)
        stamp = self._node.get_clock().now().to_msg()
        self._writer.publish(self._key.serialize(heartbeat_message(alive, stamp)))
        self.beats += 1

    def announce_again(self, late: float, starved: bool = False) -> None:
        """Make the heartbeats' writer anew: peers that dropped this participant see it again.

        A process stopped or starved past its peers' lease is dropped by them
        (docs/protocol.md, "Coming back"). When it goes on, DDS matches its
        endpoints again, but its peers' ROS graph does not show its nodes
        again: the list of a participant's nodes (``ros_discovery_info``) is
        a sample its peers' readers acknowledged before they dropped it, and
        a reader matched again is not sent it again (eProsima/Fast-DDS#2065).
        rmw_fastrtps publishes that list afresh whenever an endpoint is made:
        a new writer makes the peers' graph show this process's nodes again.
        Not every endpoint is always matched again, though (an FLS process
        taken back so was once not heard by one neighbour in any later
        round), so an FLS's own program starts afresh instead
        (``fls_program.start_afresh``); a packed process, whose FLSs the
        launcher hosts, announces itself again.
        """
        self._node.destroy_publisher(self._writer)
        self._writer = self._node.create_publisher(Heartbeat, HEARTBEAT_TOPIC, HEARTBEAT_QOS)
        self.announced_again += 1
        why = "waiting for a CPU" if starved else "its CPU idle"
        self._node.get_logger().info(
            f"its executor stood still for {late:.1f} s, {why}: peers may have dropped "
            "this process; announced it again"
        )
