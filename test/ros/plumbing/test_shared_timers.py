"""Many nodes' timers on one node's timer: each is called at its period, stops and starts
again, and a packed process's FLS nodes start no thread each."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from rclpy.experimental.events_executor import EventsExecutor

from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.shared_timers import SharedTimers
from swazure_ros.ros.programs.host import HostConfig, SwarmHost
from swazure_ros.sim.world import WorldSpec

from ...waits import PATIENCE


def spin_for(executor: EventsExecutor, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        executor.spin_once(timeout_sec=0.01)


def threads() -> int:
    """This process's threads, native ones included (rclpy's own are no Python threads)."""
    return len(os.listdir("/proc/self/task"))


def spin_until(executor: EventsExecutor, done: Callable[[], bool]) -> None:
    """Spin until ``done()``, or PATIENCE s: a busy machine runs timers late, never early."""
    end = time.monotonic() + PATIENCE
    while not done() and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.01)


def test_shared_timers_call_each_at_its_period_and_stop_and_start_again(context):
    node = SwarmNode("ticks", context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(node)
    try:
        timers = SharedTimers(node)
        calls = {"fast": 0, "slow": 0}
        began = time.monotonic()
        fast = timers.create_timer(0.05, lambda: calls.__setitem__("fast", calls["fast"] + 1))
        slow = timers.create_timer(0.2, lambda: calls.__setitem__("slow", calls["slow"] + 1))
        spin_until(executor, lambda: calls["fast"] >= 8 and calls["slow"] >= 2)
        elapsed = time.monotonic() - began
        # Late on a busy machine, a tick calls a timer once, not once for every period it
        # missed: never more often than its periods that passed, and never the slow one
        # more often than the fast one.
        assert calls["fast"] >= 8 and calls["slow"] >= 2, calls
        assert calls["fast"] <= elapsed / 0.05 + 1 and calls["slow"] <= elapsed / 0.2 + 1
        assert calls["slow"] <= calls["fast"]
        fast.cancel()
        assert fast.is_canceled() and not slow.is_canceled()
        before = dict(calls)
        spin_until(executor, lambda: calls["slow"] >= before["slow"] + 2)
        assert calls["fast"] == before["fast"] and calls["slow"] >= before["slow"] + 2
        slow.cancel()
        assert timers.running == 0
        before = dict(calls)
        spin_for(executor, 0.3)
        assert calls == before  # nothing runs, the shared timer neither
        fast.timer_period_ns = round(0.1 * 1e9)
        began = time.monotonic()
        fast.reset()
        spin_until(executor, lambda: calls["fast"] >= before["fast"] + 2)
        elapsed = time.monotonic() - began
        made = calls["fast"] - before["fast"]
        assert 2 <= made <= elapsed / 0.1 + 1 and calls["slow"] == before["slow"]
    finally:
        executor.remove_node(node)
        node.destroy_node()


def test_a_timer_that_raises_is_counted_by_its_node_and_the_others_are_still_called(context):
    host_node, fls_node = SwarmNode("host", context=context), SwarmNode("fls", context=context)
    executor = EventsExecutor(context=context)
    executor.add_node(host_node)
    try:
        timers = SharedTimers(host_node)
        calls = []

        def broken() -> None:
            raise RuntimeError("a defect")

        timers.create_timer(0.05, fls_node.guarded(broken))
        timers.create_timer(0.05, lambda: calls.append(1))
        deadline = time.monotonic() + PATIENCE
        while (len(calls) < 3 or not fls_node.failures) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        assert len(calls) >= 3
        assert sum(fls_node.failures.values()) >= 1 and not host_node.failures
    finally:
        executor.remove_node(host_node)
        host_node.destroy_node()
        fls_node.destroy_node()


def test_a_process_of_many_fls_nodes_starts_no_thread_for_each(context):
    # rclpy's EventsExecutor keeps a thread for each clock that has a timer, and every
    # node has a clock of its own: 16,384 FLS nodes in one process ran out of threads.
    world = WorldSpec("torus:400", scale=1.6, beta=0.5).build()
    host = SwarmHost(world, HostConfig(tuple(world.ids), fls_services=False), context=context)
    try:
        before = threads()
        host.create_fls_nodes()
        assert len(host.fls_nodes) == world.swarm.size > 300
        assert threads() - before < 20, threads() - before
        # Their frames still run, on the host's one timer: each FLS's first frame comes.
        deadline = time.monotonic() + PATIENCE
        while time.monotonic() < deadline and not all(
            node.frames_taken for node in host.fls_nodes
        ):
            host.spin_once(0.05)
        assert all(node.frames_taken for node in host.fls_nodes)
        assert threads() - before < 20
        # A stopped FLS's frames stop with it: the host's timer calls no destroyed node.
        stopped = host.fls_nodes[0]
        stopped._wake_frames()
        host.stop_fls(stopped.fls_id)
        host.spin_once(0.05)
        assert host.frames is not None and host.frames.running < len(host.fls_nodes) + 1
        taken = stopped.frames_taken
        end = time.monotonic() + 2.5 * stopped.publish_period  # its frame was due by then
        while time.monotonic() < end:
            host.spin_once(0.05)
        assert stopped.frames_taken == taken and not stopped.failures
    finally:
        host.close()
