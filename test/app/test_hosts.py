"""FLS processes across hosts (network namespaces) that discover through a Discovery Server.

Each host runs its share of FLS processes with the command a person would
run on each machine (`swazure spawn --per-fls --share K/2
--discovery-server IP`); the hosts have no multicast, so nothing but the
server can have told the processes of one another.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

from swazure_ros.app.share import shares
from swazure_ros.files.record import RECORD_FILE, read_record
from swazure_ros.ros.security.keys import new_key, write_key
from swazure_ros.sim.world import WorldSpec

from ..netns import address, hosts_unavailable, netns_hosts, on_host
from ..waits import PATIENCE
from .test_per_fls import GRID

SWAZURE = (sys.executable, "-m", "swazure_ros.cli.main")


@pytest.fixture
def two_hosts_without_multicast(domain):
    reason = hosts_unavailable()
    if reason is not None:
        pytest.skip(reason)
    with netns_hosts(2, SWAZURE_NETNS_MULTICAST="off") as env:
        yield env


def test_fls_processes_on_two_hosts_through_a_discovery_server_compute_the_engines_pairs(
    two_hosts_without_multicast, tmp_path
):
    env = two_hosts_without_multicast
    key = tmp_path / "swarm.key"
    write_key(key, new_key())
    common = ["spawn", str(GRID), "--per-fls", "--key-file", str(key), "--quiet",
              "--discovery-server", address(0), "--discovery-timeout", str(PATIENCE)]  # fmt: skip
    follower = subprocess.Popen(
        on_host(1, *SWAZURE, *common, "--share", "1/2", "--log-dir", str(tmp_path / "h1")),
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        leader = subprocess.run(
            on_host(0, *SWAZURE, *common, "--share", "0/2", "--log-dir", str(tmp_path / "h0"),
                    "--compute-all", "--out", str(tmp_path / "d")),
            env=env, capture_output=True, text=True, timeout=600,
        )  # fmt: skip
    finally:
        follower.send_signal(signal.SIGINT)
        out, err = follower.communicate(timeout=PATIENCE)
    assert leader.returncode == 0, leader.stdout + leader.stderr
    assert "13 processes of one FLS each, share 0 of 2" in leader.stdout, leader.stdout
    # Host 1's launcher says "swarm up" once it has discovered the whole swarm through
    # the server; on a loaded machine host 0's run (which its FLS processes answered) may
    # end first, and with it host 0's FLSs, so that line may never come. Its 12 FLS
    # processes are shown by their logs and their clean ends below.
    if "swarm up" in out:
        assert "12 processes of one FLS each, share 1 of 2" in out, out + err
    assert read_record(tmp_path / "d" / RECORD_FILE).comparison.identical, leader.stdout
    evaluate = subprocess.run(
        [*SWAZURE, "evaluate", "--cloud", str(GRID.with_suffix(".xyz")), "--scale", "1",
         "--radius", "0.5", "--out", str(tmp_path / "e")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert evaluate.returncode == 0, evaluate.stderr
    distributed = (tmp_path / "d" / "pairs.csv").read_bytes()
    assert distributed == (tmp_path / "e" / "pairs.csv").read_bytes()
    assert distributed.count(b"\n") == 1 + 144
    # The server ran on host 0 (its address), not on host 1, and every FLS ended cleanly.
    assert "Server is running" in (tmp_path / "h0" / "discovery_server_0.log").read_text()
    assert not (tmp_path / "h1" / "discovery_server_0.log").exists()
    assert "13 FLS processes stopped, every one cleanly (exit code 0)" in leader.stderr
    assert "12 FLS processes stopped, every one cleanly (exit code 0)" in err, err
    # Host 1 ran the second region of the grid's k-d split.
    grid = WorldSpec(str(GRID.with_suffix(".xyz")), scale=1, radius=0.5).assigned()
    assert sorted(path.name for path in (tmp_path / "h1").glob("fls_*.log")) == sorted(
        f"fls_{fls_id}.log" for fls_id in shares(grid, 2)[1]
    )


def test_a_bad_discovery_server_address_is_one_line(tmp_path):
    bad = subprocess.run([*SWAZURE, "spawn", str(GRID), "--per-fls", "--discovery-server",
                          "10.77.0.300"],
                         capture_output=True, text=True, timeout=PATIENCE)  # fmt: skip
    assert bad.returncode == 2
    assert "not an IPv4 address" in bad.stderr and "Traceback" not in bad.stderr
