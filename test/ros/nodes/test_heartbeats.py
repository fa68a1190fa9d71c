"""A radio's heartbeats over real DDS: it hears the controls, it is behind, it announces again."""

from __future__ import annotations

import time

import pytest

from swazure_ros.ros.nodes.heartbeats import BEHIND_AFTER
from swazure_ros.ros.plumbing.names import (
    CONTROL_TOPIC,
    HEARTBEAT_TOPIC,
    HEARTBEATS_READ_QOS,
    ROUND_QOS,
)

from ...conftest import REPO
from ...waits import wait_until
from ..conftest import make_context
from .test_radio import fls_radio


def test_a_radio_beats_when_it_hears_the_controls_and_when_its_executor_stood_still(domain):
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from swazure_interfaces.msg import DiscoveryControl, Heartbeat

    from swazure_ros.protocol.pulse import STALLED_AFTER

    fls_context, coordinator_context = make_context(domain), make_context(domain)
    node, radio = fls_radio(fls_context, 0)
    radio.listen()
    # The coordinator's side: its reader of heartbeats, and later its control writer.
    coordinator = Node("coordinator", namespace="swarm", context=coordinator_context)
    beats: list[Heartbeat] = []
    coordinator.create_subscription(Heartbeat, HEARTBEAT_TOPIC, beats.append, HEARTBEATS_READ_QOS)
    executors = [SingleThreadedExecutor(context=c) for c in (fls_context, coordinator_context)]
    executors[0].add_node(node)
    executors[1].add_node(coordinator)

    def spin(seconds: float = 0.05) -> None:
        for executor in executors:
            executor.spin_once(timeout_sec=seconds)

    try:
        # At rest, with no coordinator's controls to hear, a healthy radio says nothing.
        started = time.monotonic()
        wait_until(lambda: time.monotonic() > started + 2.0, 10, spin)
        assert beats == [] and radio.heartbeats.beats == 0
        # A coordinator's control writer matches its reader: it says it hears the controls.
        coordinator.create_publisher(DiscoveryControl, CONTROL_TOPIC, ROUND_QOS)
        assert wait_until(lambda: beats, 60, spin), "no heartbeat once the controls matched"
        assert beats[-1].host == "fls_0" and beats[-1].hears_controls
        assert beats[-1].late == 0.0
        # Its executor stands still in one callback for a few seconds: it says it was behind.
        said = len(beats)
        stood = BEHIND_AFTER + 2.0
        timer = node.create_timer(0.01, lambda: (node.destroy_timer(timer), time.sleep(stood)))
        assert wait_until(lambda: len(beats) > said, 60, spin), "no heartbeat after the stall"
        assert beats[-1].hears_controls and beats[-1].late > BEHIND_AFTER
        assert radio.heartbeats.announced_again == 0  # too short for a lease to lapse
        # Standing still past a lease could lapse, CPU idle: it announces itself again
        # (a new writer), and its beat reaches the coordinator through the new writer.
        said = len(beats)
        stood = STALLED_AFTER + 2.0
        timer = node.create_timer(0.01, lambda: (node.destroy_timer(timer), time.sleep(stood)))
        assert wait_until(lambda: radio.heartbeats.announced_again == 1, 60, spin)
        assert wait_until(lambda: len(beats) > said, 60, spin), "no heartbeat after announcing"
        assert beats[-1].late > STALLED_AFTER
        # Told what to do after a stall of its own length (an FLS's program: start afresh),
        # it does that instead, and only past that length.
        stalls: list[float] = []
        radio.heartbeats.when_stalled(BEHIND_AFTER + 1.0, stalls.append)
        stood = BEHIND_AFTER + 2.5
        timer = node.create_timer(0.01, lambda: (node.destroy_timer(timer), time.sleep(stood)))
        assert wait_until(lambda: stalls, 60, spin), "a stall past its length did nothing"
        assert stalls[0] > BEHIND_AFTER + 1.0 and radio.heartbeats.announced_again == 1
    finally:
        for executor in executors:
            executor.shutdown()
        node.destroy_node()
        coordinator.destroy_node()
        fls_context.try_shutdown()
        coordinator_context.try_shutdown()


def test_the_coordinator_keeps_no_more_radios_than_the_swarm_can_have(context):
    """Heartbeats under made-up radio names (anyone can send them under --no-key) fill the
    coordinator's list of radios that hear the controls only up to one per FLS and process."""
    from swazure_interfaces.msg import Heartbeat

    from swazure_ros.ros.nodes.coordinator import Coordinator
    from swazure_ros.ros.plumbing.names import HEARTBEAT_TOPIC
    from swazure_ros.sim.world import WorldSpec

    world = WorldSpec(cloud=str(REPO / "config/track/trio.xyz"), scale=1.0, radius=0.5).build()
    coordinator = Coordinator(
        world.ids.tolist(), 3, shape=world.swarm, sensor=world.sensor, context=context
    )
    try:
        for name in [f"made_up_{k}" for k in range(20)] + ["fls_0"]:
            beat = Heartbeat(host=name, hears_controls=True)
            coordinator.guard.call(HEARTBEAT_TOPIC, coordinator._on_heartbeat, beat)
        assert len(coordinator._hearing) == 3 + 3
        refused = coordinator.guard.dropped[(HEARTBEAT_TOPIC, "more radios than FLSs")]
        assert refused == 20 + 1 - 6
        # A radio it keeps may say it no longer hears; one it knows may say it hears again.
        coordinator.guard.call(
            HEARTBEAT_TOPIC, coordinator._on_heartbeat, Heartbeat(host="made_up_0")
        )
        assert "made_up_0" not in coordinator._hearing
    finally:
        coordinator.destroy_node()


#: A process on one CPU shared with a busy one: it sleeps 1 s, then its main thread waits
#: on an event while a thread of its own spins 1 s (alive after, so its wait still counts).
_SHARED_CPU = """
import json, os, sys, threading, time
from swazure_ros.ros.nodes.heartbeats import waited_for_cpu
os.sched_setaffinity(0, {int(sys.argv[1])})
time.sleep(0.5)
start = waited_for_cpu()
time.sleep(1.0)
slept = waited_for_cpu() - start
spun, leave = threading.Event(), threading.Event()
def spin():
    until = time.monotonic() + 1.0
    while time.monotonic() < until:
        pass
    spun.set()
    leave.wait()
spinner = threading.Thread(target=spin)
start = waited_for_cpu()
spinner.start()
spun.wait()
blocked = waited_for_cpu() - start
leave.set()
spinner.join()
print(json.dumps({"slept": slept, "blocked": blocked}))
"""


def test_a_process_kept_from_a_cpu_counts_its_threads_wait_and_a_sleeping_one_does_not():
    """An executor blocked on a lock is asleep; the process was starved all the same if
    another of its threads waited for a CPU meanwhile (a DDS thread under load)."""
    import json
    import os
    import subprocess
    import sys

    if not os.path.exists("/proc/self/task"):
        pytest.skip("this system lists no threads of a process (/proc/self/task)")
    cpu = min(os.sched_getaffinity(0))
    # A busy process on the measured process's one CPU, at its priority: the CPU is shared.
    busy = subprocess.Popen(
        [sys.executable, "-c", f"import os; os.sched_setaffinity(0, {{{cpu}}})\nwhile True: pass"]
    )
    try:
        measured = subprocess.run(
            [sys.executable, "-c", _SHARED_CPU, str(cpu)],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        )
    finally:
        busy.kill()
        busy.wait()
    waits = json.loads(measured.stdout.splitlines()[-1])
    if waits["slept"] == waits["blocked"] == 0.0:
        pytest.skip("this kernel keeps no scheduler statistics (schedstat)")
    # Blocked on an event while its spinning thread shared the CPU with another spinner for
    # 1 s: the process waited for about half of it, though the caller did not wait to run.
    assert waits["blocked"] > 0.2
    # Asleep, it waited to run only for the moments it woke: a small part of that, however
    # busy the machine (a bound in seconds would assume a quiet one).
    assert waits["slept"] < waits["blocked"] / 4


def test_a_radio_heard_by_its_heartbeat_leaves_the_hosts_with_its_fls(context):
    """Each FLS its own process (3 radios): the radios whose heartbeats say they hear the
    controls are known before any graph look, so an FLS killed as its swarm came up takes
    its radio from the hosts a round waits for (it once held every later round)."""
    from swazure_interfaces.msg import Heartbeat

    from swazure_ros.ros.nodes.coordinator import Coordinator
    from swazure_ros.ros.plumbing.names import HEARTBEAT_TOPIC
    from swazure_ros.sim.world import WorldSpec

    world = WorldSpec(cloud=str(REPO / "config/track/trio.xyz"), scale=1.0, radius=0.5).build()
    coordinator = Coordinator(
        world.ids.tolist(), 3, shape=world.swarm, sensor=world.sensor, context=context
    )
    try:
        for name in ("fls_0", "fls_1", "fls_2"):
            beat = Heartbeat(host=name, hears_controls=True)
            coordinator.guard.call(HEARTBEAT_TOPIC, coordinator._on_heartbeat, beat)
        assert coordinator.membership.radios == {"fls_0", "fls_1", "fls_2"}
        assert coordinator.membership.lose({1}) == 1
        assert coordinator.membership.hosts == 2
        # Its heartbeat, late, does not count it again.
        beat = Heartbeat(host="fls_1", hears_controls=True)
        coordinator.guard.call(HEARTBEAT_TOPIC, coordinator._on_heartbeat, beat)
        assert coordinator.membership.radios == {"fls_0", "fls_2"}
    finally:
        coordinator.destroy_node()
