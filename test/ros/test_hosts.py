"""A swarm across three hosts (network namespaces on a bridge): discovery identical to the engine.

Each host runs its share with the command a person would run on each real
machine (`swazure spawn ... --share K/3`), over UDP only, discovering the
others by multicast on their subnet (scripts/netns_hosts.sh).
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from swazure_ros.files.record import RECORD_FILE, read_record

from ..netns import SCRIPT, hosts_unavailable, netns_hosts, on_host
from ..waits import PATIENCE

SWARM = ["--cloud", "torus:120", "--scale", "1.6", "--beta", "0.5", "--quiet"]


@pytest.fixture
def hosts(domain, tmp_path):
    reason = hosts_unavailable()
    if reason is not None:
        pytest.skip(reason)
    # A host that compiles the numba kernels for the first time (a fresh clone) stalls
    # for seconds in its first round: longer than the default round timeout, and the
    # others would take its FLSs for departed.
    params = tmp_path / "swarm.yaml"
    params.write_text("/**/coordinator:\n  ros__parameters:\n    round_timeout: 120.0\n")
    with netns_hosts(3, PARAMS=str(params)) as env:
        yield env


def on_host_spawn(env, index, *arguments):
    command = on_host(index, sys.executable, "-m", "swazure_ros.cli.main")
    return [*command, "spawn", *SWARM, "--params", env["PARAMS"], "--share", f"{index}/3",
            *arguments]  # fmt: skip


def test_three_hosts_discover_as_the_engine_does(hosts, tmp_path):
    env = hosts
    served = [
        subprocess.Popen(on_host_spawn(env, index), env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
        for index in (1, 2)
    ]  # fmt: skip
    try:
        leader = subprocess.run(
            on_host_spawn(env, 0, "--compute-all", "--discovery-timeout", str(PATIENCE),
                          "--out", str(tmp_path / "d")),
            env=env, capture_output=True, text=True, timeout=2 * PATIENCE,
        )  # fmt: skip
    finally:
        for process in served:
            process.terminate()
        outputs = [process.communicate(timeout=PATIENCE) for process in served]
    assert leader.returncode == 0, leader.stderr
    assert "120 FLS nodes in 3 hosts (this is share 0)" in leader.stdout
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.comparison.identical, leader.stdout + leader.stderr
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
