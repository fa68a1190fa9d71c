"""A swarm across three hosts (network namespaces on a bridge): discovery identical to the engine.

Each host runs its share with the command a person would run on each real
machine (`swazure spawn ... --share K/3`), over UDP only, discovering the
others by multicast on their subnet (scripts/netns_hosts.sh).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

from ..conftest import REPO

SCRIPT = REPO / "scripts" / "netns_hosts.sh"
SWARM = ["--cloud", "torus:120", "--scale", "1.6", "--beta", "0.5", "--quiet"]


def _hosts_possible() -> str | None:
    if os.geteuid() != 0:
        return "network namespaces need root"
    if shutil.which("ip") is None:
        return "the ip command (iproute2) is not installed"
    probe = subprocess.run(["ip", "netns", "add", "swzprobe"], capture_output=True, text=True)
    if probe.returncode != 0:
        return f"cannot make a network namespace here: {probe.stderr.strip()}"
    subprocess.run(["ip", "netns", "delete", "swzprobe"], capture_output=True)
    return None


@pytest.fixture
def hosts(domain, tmp_path):
    reason = _hosts_possible()
    if reason is not None:
        pytest.skip(reason)
    # A host that compiles the numba kernels for the first time (a fresh clone) stalls
    # for seconds in its first round: longer than the default round timeout, and the
    # others would take its FLSs for departed.
    params = tmp_path / "swarm.yaml"
    params.write_text("/**/coordinator:\n  ros__parameters:\n    round_timeout: 120.0\n")
    env = dict(os.environ, SWAZURE_NETNS_PREFIX=f"swz{os.getpid() % 10000}", PARAMS=str(params))
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)  # the script sets SUBNET on each host
    up = subprocess.run([str(SCRIPT), "up", "3"], env=env, capture_output=True, text=True)
    assert up.returncode == 0, up.stderr
    try:
        yield env
    finally:
        subprocess.run([str(SCRIPT), "down"], env=env, capture_output=True)


def on_host(env, index, *arguments):
    command = [str(SCRIPT), "exec", str(index), sys.executable, "-m", "swazure_ros.cli.main"]
    return [*command, "spawn", *SWARM, "--params", env["PARAMS"], "--share", f"{index}/3",
            *arguments]  # fmt: skip


def test_three_hosts_discover_as_the_engine_does(hosts):
    env = hosts
    served = [
        subprocess.Popen(on_host(env, index), env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
        for index in (1, 2)
    ]  # fmt: skip
    try:
        leader = subprocess.run(
            on_host(env, 0, "--compute-all", "--discovery-timeout", "90"),
            env=env, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
    finally:
        for process in served:
            process.terminate()
        outputs = [process.communicate(timeout=60) for process in served]
    assert leader.returncode == 0, leader.stderr
    assert "120 FLS nodes in 3 hosts (this is share 0)" in leader.stdout
    assert (
        "pairs identical to the engine's (status, path, estimate to 1e-9): yes" in leader.stdout
    ), leader.stdout + leader.stderr
    for index, (stdout, _) in zip((1, 2), outputs, strict=True):
        assert f"120 FLS nodes in 3 hosts (this is share {index})" in stdout


def test_the_hosts_script_refuses_a_bad_count_and_cleans_up(hosts):
    env = hosts
    bad = subprocess.run([str(SCRIPT), "up", "zero"], env=env, capture_output=True, text=True)
    assert bad.returncode == 2 and "host count" in bad.stderr
    missing = subprocess.run([str(SCRIPT), "exec", "7", "true"], env=env, capture_output=True,
                             text=True)  # fmt: skip
    assert missing.returncode == 2 and "no host 7" in missing.stderr
    subprocess.run([str(SCRIPT), "down"], env=env, check=True)
    left = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert env["SWAZURE_NETNS_PREFIX"] + "h" not in left
