"""Helpers of the ROS tests: the engine's expected values, and collecting messages."""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from swazure_ros.core.frames import to_centimetres
from swazure_ros.core.hop_errors import measured_vectors
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.sensor import BLIND, DECAYING, SWEET
from swazure_ros.ros.plumbing import shared_memory

from ..waits import PATIENCE, wait_until

#: A Fast DDS participant lease of an hour (announced every 5 s), far longer than any
#: wait of a test: a peer that drops a process's nodes within a test's wait was told the
#: process left; it did not wait for the lease to run out. (The swarm's own is 20 s, and a
#: test that asserted "gone within 10 s" flaked at 10.2 s on a busy machine.)
LONG_LEASE = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <profiles>
    <participant profile_name="long_lease" is_default_profile="true">
      <rtps><builtin><discovery_config>
        <leaseDuration><sec>3600</sec></leaseDuration>
        <leaseAnnouncement><sec>5</sec></leaseAnnouncement>
      </discovery_config></builtin></rtps>
    </participant>
  </profiles>
</dds>
"""


def with_shared_memory(environment: dict[str, str]) -> dict[str, str]:
    """``environment`` with Fast DDS's default transports, shared memory among them."""
    return {k: v for k, v in environment.items() if k != "FASTDDS_BUILTIN_TRANSPORTS"}


def long_lease_environment(folder: Path, environment: dict[str, str]) -> dict[str, str]:
    """``environment`` with every participant of its processes on an hour's lease."""
    profile = folder / "long-lease.xml"
    profile.write_text(LONG_LEASE)
    return dict(environment, FASTRTPS_DEFAULT_PROFILES_FILE=str(profile))


def engine_expectations(world):
    """Per FLS id: {target id: measured vector} and its neighbour id sets, from the engine."""
    hood = neighbourhood(world.swarm, world.sensor)
    pairs, ids = hood.pairs, world.ids
    vectors, sets = {}, {}
    for fls_id in ids.tolist():
        vectors[fls_id] = {}
        sets[fls_id] = {"blind": set(), "sweet": set(), "visible_sweet": set(), "decaying": set()}
    for first, second, kind, visible in zip(
        pairs.first.tolist(), pairs.second.tolist(), pairs.range_class.tolist(), hood.visible
    ):
        for owner, other in ((first, second), (second, first)):
            entry = sets[int(ids[owner])]
            if kind == BLIND:
                entry["blind"].add(int(ids[other]))
            elif kind == SWEET:
                entry["sweet"].add(int(ids[other]))
                if visible:
                    entry["visible_sweet"].add(int(ids[other]))
            elif kind == DECAYING and visible:
                entry["decaying"].add(int(ids[other]))
            if kind in (SWEET, DECAYING) and visible:
                vector = measured_vectors(
                    world.sensor, world.swarm.points, world.swarm.radius, [owner], [other]
                )[0]
                vectors[int(ids[owner])][int(ids[other])] = vector
    return vectors, sets


def spin_until(executor, condition, timeout=PATIENCE):
    """Spin ``executor`` until ``condition()`` holds; return whether it did."""
    return wait_until(condition, timeout, lambda: executor.spin_once(timeout_sec=0.05))


def received_vectors(message):
    """{target id: (3,) vector, cm} of a Measurements message (which carries metres)."""
    return {
        pose.target_id: to_centimetres(np.array([pose.vector.x, pose.vector.y, pose.vector.z]))
        for pose in message.poses
    }


#: A reader of the latched measurements: it gets each FLS's last message when it joins.
LATCHED = QoSProfile(
    depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
#: The same reader asked of `ros2 topic echo`. The measurements are sent once while
#: unchanged; left to itself, echo takes the durability of the publishers it found within
#: its spin time and, finding none yet, reads volatile: a volatile reader skips what was
#: sent before it matched the publisher, and then waits for ever (1 CI run in about 12).
ECHO_LATCHED = [
    "--qos-reliability", "reliable", "--qos-durability", "transient_local",
    # Keep every latched message a late reader is sent: a depth cuts a big swarm's short.
    "--qos-history", "keep_all",
]  # fmt: skip


def matches(message, expected_vectors):
    """True when a Measurements message holds exactly ``expected_vectors`` ({id: (3,)})."""
    try:
        assert_matches(message, expected_vectors)
    except AssertionError:
        return False
    return True


def assert_matches(message, expected_vectors):
    """Fail unless a Measurements message holds exactly ``expected_vectors``, to 1e-12 cm."""
    got = received_vectors(message)
    assert set(got) == set(expected_vectors), (message.source_id, sorted(got))
    for target, vector in got.items():
        np.testing.assert_allclose(vector, expected_vectors[target], rtol=0, atol=1e-12)


def radio_topics(world_spec) -> list[str]:
    """The radio cells' topics the FLSs of ``world_spec`` send their offers on, both bands."""
    from swazure_ros.protocol.cells import BANDS, radio_cells
    from swazure_ros.ros.plumbing.names import radio_topic

    assigned = world_spec.assigned()
    grids = radio_cells(world_spec.sensor(), assigned.radius)
    return sorted(
        f"/swarm/{radio_topic(band, cell)}"
        for band in BANDS
        for cell in np.unique(grids[band].of(assigned.points), axis=0)
    )


def joined(by_topic, topics) -> list:
    """The messages of ``topics`` in ``by_topic`` (topic -> list), in one list."""
    return [message for topic in topics for message in by_topic.get(topic, [])]


def start_ros2(command: list[str], environment: dict[str, str]) -> subprocess.Popen[str]:
    """Start a ros2 CLI ``command``, its output piped, in a process group to stop it by."""
    return subprocess.Popen(
        command,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=environment,
        start_new_session=True,
    )


def free_udp_port() -> int:
    """A UDP port that nothing on this machine holds now, for a test's Discovery Server.

    The kernel's choice, from its ephemeral range (from 32768): above every port Fast DDS
    derives for the suite's domains (1-100: 7400 + 250 x domain + a few hundred). A port
    derived from the domain, as ``11811 + domain`` was, fell among the ports a test held
    for the same domain's participants (domain 17: 11828, a fresh clone's suite, 2026-12-07).
    """
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


#: Wall s one ros2 CLI command may take: seconds as a rule, tens on a loaded machine.
ROS2_CALL_TIMEOUT = 120.0


def run_ros2(
    command: list[str], environment: dict[str, str], timeout: float = ROS2_CALL_TIMEOUT
) -> subprocess.CompletedProcess[str]:
    """Run a ros2 CLI ``command`` to its end, or kill it at ``timeout`` s; what it printed.

    A ros2 command can print all it has to say and then hang tearing its own node
    down (Fast DDS 2.14, eProsima/Fast-DDS#6502: `ros2 topic echo --once` did for over
    300 s on a loaded CI machine, 2026-11-29; see :func:`echo_first`). Killed, it
    returns its output with return code -9 (SIGKILL), for the caller to judge: a
    retried call (``until``) takes an answer it printed before it hung.
    """
    with start_ros2(command, environment) as process:
        try:
            out, err = process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            owned = shared_memory.own_segments(process.pid)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            out, err = process.communicate()
            shared_memory.remove(owned)  # its DDS teardown never will
    return subprocess.CompletedProcess(command, process.returncode, out, err)


#: Wall s a ros2 call that asks a node (a service, a parameter) may take before it
#: counts as hung: it starts, finds the node and is answered in well under this on a
#: loaded machine.
ROS2_ASK_TIMEOUT = 60.0


def ask_ros2(
    run: Callable[[float], subprocess.CompletedProcess[str]],
    accept: Callable[[subprocess.CompletedProcess[str]], bool] = lambda result: True,
    timeout: float = PATIENCE,
    call_timeout: float = ROS2_ASK_TIMEOUT,
) -> subprocess.CompletedProcess[str]:
    """``run(call_timeout)`` (a `ros2 service call`, `ros2 param`) again until it ends by
    itself with a result ``accept`` takes, or ``timeout`` s pass; the last result.

    ros2service and ros2param spin for the response with no deadline, and a response
    lost while the two ends still match (ros2/system_tests#420) leaves the call waiting
    for good: CI saw a `ros2 param get` through a Discovery Server killed after 120 s,
    having said nothing (2026-12-07). A person presses Ctrl-C and asks again; so does
    this (:func:`run_ros2` kills a call at its timeout: exit -9). Every call asked so
    gets, or sets a value already chosen: asking again changes nothing.
    """
    results: list[subprocess.CompletedProcess[str]] = []

    def answered() -> bool:
        last = results[-1] if results else None
        return last is not None and last.returncode != -signal.SIGKILL and accept(last)

    wait_until(answered, timeout, lambda: results.append(run(call_timeout)))
    return results[-1] if results else run(call_timeout)


def interrupt_ros2(process: subprocess.Popen[str], patience: float = 30.0) -> None:
    """Stop a ros2 CLI process as a person would: Ctrl-C (SIGINT to its group), and Ctrl-C
    again when the first goes unheeded for ``patience`` s; killed if neither ends it.

    Seen once (2026-11-30, make test from a fresh clone): a `ros2 topic echo` sat in
    rcl_wait for over 300 s after the first SIGINT, and a second one ended it at once.
    How the ros2 CLI's own node winds down is ros2cli's and Fast DDS's (see
    :func:`run_ros2`), not what a test of the swarm asserts.
    """
    for _ in range(2):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(timeout=patience)
            return
        except subprocess.TimeoutExpired:
            continue
    shared_memory.kill(process, group=True)


def echo_first(
    command: list[str],
    environment: dict[str, str],
    timeout: float = PATIENCE,
    step: Callable[[], object] | None = None,
) -> str:
    """The first message a real ``ros2 topic echo`` prints, up to its ``---`` line.

    ``command`` is the whole echo command (with ``--once``); ``step()`` is called while
    nothing is printed yet (send a request that makes the message, say). The echo is
    stopped once the message is out rather than waited for: `ros2 topic echo --once`
    printed its message and then hung for over 300 s tearing its node down, on a loaded
    CI machine (2026-11-29). What the swarm sent is what our tests assert; how the ros2
    CLI's own node winds down is ros2cli's and Fast DDS's.

    Raises
    ------
    AssertionError
        When nothing was printed within ``timeout`` s; the message has what echo said.
    """
    lines: list[str] = []
    errors: list[str] = []

    def printed() -> bool:
        return "---\n" in list(lines)

    def wait_a_little() -> None:
        if step is not None:
            step()
        wait_until(printed, 5.0)

    with start_ros2(command, environment) as echo:
        readers = [
            threading.Thread(target=lambda: lines.extend(echo.stdout), daemon=True),
            threading.Thread(target=lambda: errors.extend(echo.stderr), daemon=True),
        ]
        for reader in readers:
            reader.start()
        try:
            wait_until(printed, timeout, wait_a_little)
        finally:
            if echo.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(echo.pid, signal.SIGINT)
                try:
                    echo.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    shared_memory.kill(echo, group=True)
            for reader in readers:
                reader.join(timeout=10)
    taken = list(lines)
    assert "---\n" in taken, f"ros2 topic echo printed no message: {''.join(errors)[-2000:]}"
    return "".join(taken[: taken.index("---\n") + 1])
