"""Shared fixtures: hand-built swarms whose answers are obvious, and paths to shared data."""

from __future__ import annotations

import contextlib
import faulthandler
import os
import select
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from swazure_ros.core.arrays import FloatArray
from swazure_ros.core.geometry import Swarm, make_swarm
from swazure_ros.core.sensor import Sensor
from swazure_ros.ros.plumbing import shared_memory

from .domains import configured_domains, held_domain

#: The fuzz tests' hypothesis settings: the same inputs every run (seeded, no example
#: database), no time limit per example; each test sets its own max_examples.
FUZZ = settings(
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
DATASETS = SHARED / "datasets" / "swazure-paper"

# Hand-built scene, r = 0.5 cm so t = d - 1. Indices: A=0, B=1, C=2, K=3, D=4.
A, B, C, K, D = 0, 1, 2, 3, 4
SCENE = np.array(
    [
        [0.0, 0.0, 0.0],  # A
        [2.0, 7.0, 0.0],  # B: sweet to A and C (t = 6.28)
        [4.0, 0.0, 0.0],  # C: blind to A (t = 3)
        [1.0, 3.5, 0.0],  # K: on segment A-B, obstructs it; blind to A, B, C
        [2.0, -10.0, 0.0],  # D: decaying to A and C (t = 9.2), in sight of both
    ]
)


def ros2_daemons(domain: int) -> dict[int, int]:
    """The ros2 CLI's daemons on this machine that serve ROS domain ``domain``: a pidfd of
    each (os.pidfd_open) by process id, to be closed by the caller.

    A pidfd names the process, not its number: this machine's process ids wrap at
    32,768, and a suite starts thousands of processes, so a number read now may
    name another process by the time it is signalled.
    """
    found = {}
    wanted = f"ROS_DOMAIN_ID={domain}".encode()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and _is_daemon(entry, wanted):
            with contextlib.suppress(OSError):  # ended meanwhile
                pidfd = os.pidfd_open(int(entry.name))
                # Read again with the process held: the number named a daemon when opened.
                if _is_daemon(entry, wanted):
                    found[int(entry.name)] = pidfd
                else:
                    os.close(pidfd)
    return found


def _is_daemon(entry: Path, wanted: bytes) -> bool:
    """Whether process folder ``entry`` is a ros2 daemon whose environment holds ``wanted``."""
    try:
        command = (entry / "cmdline").read_bytes()
        if b"ros2cli.daemon.daemonize" not in command:
            return False
        return wanted in (entry / "environ").read_bytes().split(b"\0")
    except OSError:
        return False


#: Seconds a ros2 daemon has to end after SIGTERM before it is killed. Its DDS teardown can
#: hang, spinning a core in DomainParticipant::set_listener (Fast-DDS#6502): one ignored its
#: SIGTERM and spun through the rest of a suite and after it (2026-11-30, gdb).
DAEMON_TEARDOWN = 5.0


def stop_ros2_daemons(domain: int) -> None:
    """Stop the daemons that the ros2 commands of a test on ``domain`` started.

    By domain, not at the end of the session: with tests on two workers
    (pytest-xdist), another worker's test may be using its own daemon. One still
    there DAEMON_TEARDOWN s after SIGTERM is killed, and its shared memory removed.
    Signalled through pidfds (:func:`ros2_daemons`): a daemon that ended is never
    mistaken for a process that took its number since.
    """
    daemons = ros2_daemons(domain)
    try:
        for pidfd in daemons.values():
            with contextlib.suppress(ProcessLookupError):
                signal.pidfd_send_signal(pidfd, signal.SIGTERM)
        left = still_running(daemons, DAEMON_TEARDOWN)
        for pid, pidfd in left.items():
            owned = shared_memory.own_segments(pid)
            with contextlib.suppress(ProcessLookupError):
                signal.pidfd_send_signal(pidfd, signal.SIGKILL)
            shared_memory.remove(owned)
        still_running(left, DAEMON_TEARDOWN)
    finally:
        for pidfd in daemons.values():
            os.close(pidfd)


def still_running(pidfds: dict[int, int], seconds: float) -> dict[int, int]:
    """Wait up to ``seconds`` for the processes of ``pidfds`` to end; those still running.

    A pidfd turns readable when its process ends, whoever reaps it; its number
    may name another process by then, the pidfd never does.
    """
    deadline = time.monotonic() + seconds
    left = dict(pidfds)
    while left:
        wait = max(deadline - time.monotonic(), 0.0)
        ready, _, _ = select.select(list(left.values()), [], [], wait)
        left = {pid: pidfd for pid, pidfd in left.items() if pidfd not in ready}
        if time.monotonic() >= deadline:
            break
    return left


def running(pid: int) -> bool:
    """Whether process ``pid`` is there and has not ended (a zombie has ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def pytest_configure(config: pytest.Config) -> None:
    """Refuse a malformed SWAZURE_TEST_DOMAINS at once; keep stray DDS traffic to itself.

    A test that talks over DDS takes the ``domain`` fixture: a domain id of its
    own, discovery on this machine only. Anything else that starts DDS (a test
    that forgot the fixture) gets no discovery at all rather than domain 0's
    traffic, so it fails here instead of meeting somebody else's swarm.
    """
    try:
        configured_domains()
    except ValueError as error:
        raise pytest.UsageError(str(error)) from None
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"
    os.environ.pop("ROS_DOMAIN_ID", None)
    # A worker ended by SIGTERM dies without Python's fault report, and pytest-xdist says
    # only that it crashed: this prints every thread's stack first, then ends it as before.
    # To a copy of the terminal's stderr (faulthandler holds it): a test's own is captured
    # into a file, and so is this conftest's import; pytest's capture pauses here.
    terminal = os.fdopen(os.dup(2), "w")
    faulthandler.register(signal.SIGTERM, file=terminal, all_threads=True, chain=True)


#: The files whose tests take a minute or more each (the durations of `make test`,
#: 2026-11-29), longest first. pytest-xdist's worksteal hands each worker half of the
#: collection and lets an idle worker take the end of the other's queue: a minute-long
#: test left at the end runs alone while the other worker idles. Run first, these end
#: while the short tests after them balance the workers. Not simply the longest
#: first: ordered so, the two workers started on 25-process swarms at once (load 29 in a
#: fresh clone's suite, 2026-11-29); CI ran this order's suite in 20 min.
SLOW_FILES = (
    "test/protocol/test_discovery.py",
    "test/cli/test_study_cli.py",
    "test/ros/test_hosts.py",
    "test/ros/test_discovery.py",
    "test/core/test_fit.py",
    "test/ros/programs/test_programs.py",
    "test/ros/test_scale.py",
    "test/app/test_hosts.py",
    "test/protocol/test_swarm_fit.py",
    "test/app/test_per_fls.py",
    "test/ros/test_cells.py",
    "test/core/test_summary.py",
    "test/files/test_hostile_files.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The slow files first (SLOW_FILES' order), each file's tests in their own order."""
    rank = {name: number for number, name in enumerate(SLOW_FILES)}

    def file_rank(item: pytest.Item) -> int:
        name = item.path.relative_to(REPO).as_posix() if item.path.is_relative_to(REPO) else ""
        return rank.get(name, len(SLOW_FILES))

    items.sort(key=file_rank)  # stable: the rest keep the collection's order


@pytest.fixture
def domain() -> Iterator[int]:
    """A ROS domain id that SWAZURE_TEST_DOMAINS allows and no other test holds now.

    Set in the environment for the test's length (with discovery on this
    machine only), so that the processes it starts share it.
    """
    saved = {
        key: os.environ.get(key) for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")
    }
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    with held_domain(configured_domains()) as reserved:
        os.environ["ROS_DOMAIN_ID"] = str(reserved)
        try:
            yield reserved
        finally:
            stop_ros2_daemons(reserved)
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


@pytest.fixture
def sensor() -> Sensor:
    """The published sensor: sweet 6-8 cm, decaying 8-30 cm, quadratic error."""
    return Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755), "published")


def scene(*indices: int) -> Swarm:
    """A swarm of the hand-built scene's FLSs ``indices`` (in that order), r = 0.5 cm."""
    return make_swarm(SCENE[list(indices)], radius=0.5)


def dataset(name: str) -> Path:
    """A published point cloud, or skip when ../shared is not beside the repo."""
    path = DATASETS / name
    if not path.exists():
        pytest.skip(f"published data set {path} is absent (../shared is not beside the repo)")
    return path


def source_body_scene() -> FloatArray:
    """Move Source's source 0 with its body in the way: (4, 3) points, cm, for r = 0.5.

    Pair (0, 2) is BLOCKED: 0's sweet neighbour 1 is hidden by 3 at the middle of
    0-1, and 2 is blind to 0. The source's first successful probe is 3 r along
    the first direction, (-1, -1, -1) / sqrt(3), with helper 1; that probe lies on
    the segment from 1 to 2, 7.2 cm from 1 and 1.3 cm from 2, so the source's own
    body there hides 2 from 1. The next direction, (-1, -1, 0) / sqrt(2), at 3 r
    leaves that view clear.
    """
    first = -np.ones(3) / np.sqrt(3)
    probe = 1.5 * first
    # The helper 8 cm from the source (sweet to it by distance) and 7.2 cm from the probe.
    along = (64.0 - 1.5**2 - 7.2**2) / (2 * 7.2 * 1.5)
    way = along * first + np.sqrt(1 - along**2) * np.array([1.0, -1.0, 0.0]) / np.sqrt(2)
    helper, target = probe + 7.2 * way, probe - 1.3 * way
    return np.array([np.zeros(3), helper, target, helper / 2])
