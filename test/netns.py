"""Hosts on this machine for tests: network namespaces made by scripts/netns_hosts.sh."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
from collections.abc import Iterator

from .conftest import REPO

SCRIPT = REPO / "scripts" / "netns_hosts.sh"
#: The address of host K is SUBNET.(10 + K) (scripts/netns_hosts.sh).
SUBNET = "10.77.0"


def hosts_unavailable() -> str | None:
    """Why network namespaces cannot be made here, or None when they can."""
    if os.geteuid() != 0:
        return "network namespaces need root"
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed"
    # A name of this process's own: tests on two workers probe at the same time.
    name = f"swzprobe{os.getpid()}"
    probe = subprocess.run(["ip", "netns", "add", name], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"cannot make a network namespace here: {probe.stderr.strip()}"
    subprocess.run(["ip", "netns", "delete", name], capture_output=True)
    return None


def address(index: int) -> str:
    """The IPv4 address of host ``index``."""
    return f"{SUBNET}.{10 + index}"


@contextlib.contextmanager
def netns_hosts(count: int, **environment: str) -> Iterator[dict[str, str]]:
    """Hosts 0..count-1 of a prefix of this test process's own; yields the environment to use."""
    env = dict(os.environ, SWAZURE_NETNS_PREFIX=f"swz{os.getpid() % 10000}", **environment)
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)  # the script sets SUBNET on each host
    up = subprocess.run([str(SCRIPT), "up", str(count)], env=env, capture_output=True, text=True)
    assert up.returncode == 0, up.stderr
    try:
        yield env
    finally:
        subprocess.run([str(SCRIPT), "down"], env=env, capture_output=True)


def on_host(index: int, *command: str) -> list[str]:
    """``command`` run on host ``index``, as on that machine."""
    return [str(SCRIPT), "exec", str(index), *command]
