"""One process per FLS across hosts: bring-up, memory, idle CPU, traffic, identity and faults.

Runs on host 0 of scripts/netns_hosts.sh (``netns_hosts.sh exec 0 python -m
bench.measure_hosts ...``, as the bench's ``hosts`` section does):
this process is the leader (simulator, coordinator and host 0's share of FLS
processes, app.swarm.RunningSwarm); it starts hosts 1..H-1's shares with the
command a person would run on each (``swazure spawn --per-fls --share K/H``),
measures, and writes one JSON record (--out). The hosts' eth0 counters give
the traffic; /proc gives every process's memory and CPU.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from swazure_ros.app.per_fls import FLS_PROGRAM

REPO = Path(__file__).resolve().parents[1]
SCRIPT = REPO / "scripts" / "netns_hosts.sh"
SWAZURE = [sys.executable, "-m", "swazure_ros.cli.main"]
POLICY = "shortest-length"
#: The shape: the built-in torus of N FLSs, spaced as test/ros/test_hosts.py's.
SCALE, BETA = 1.6, 0.5
#: What tells an FLS process by its command line: the program the launcher starts.
FLS_MARKER = FLS_PROGRAM[-1].encode()
#: Memory one FLS process takes of the machine (Pss 43-60 MB measured), with room to spare.
FLS_MB = 70.0


def prefix() -> str:
    return os.environ.get("SWAZURE_NETNS_PREFIX", "swz")


def address(index: int) -> str:
    return f"{os.environ.get('SWAZURE_NETNS_SUBNET', '10.77.0')}.{10 + index}"


def sent(hosts: int) -> tuple[int, int]:
    """(packets, bytes) every host has sent on its link so far."""
    packets = octets = 0
    for index in range(hosts):
        shown = subprocess.run(
            ["ip", "-j", "-s", "-n", f"{prefix()}h{index}", "link", "show", "eth0"],
            capture_output=True, text=True, check=True,
        )  # fmt: skip
        tx = json.loads(shown.stdout)[0]["stats64"]["tx"]
        packets += int(tx["packets"])
        octets += int(tx["bytes"])
    return packets, octets


def swarm_pids(root: Path) -> dict[str, list[int]]:
    """Process ids under ``root`` by kind: the FLS processes and the other hosts' launchers."""
    marker = str(root).encode()
    found: dict[str, list[int]] = {"fls": [], "launchers": []}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == os.getpid():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if marker in cmdline and FLS_MARKER in cmdline:
            found["fls"].append(int(entry.name))
        elif marker in cmdline and b"swazure_ros.cli.main" in cmdline and b"ip\0" not in cmdline:
            found["launchers"].append(int(entry.name))
    return found


def fls_pid(root: Path, fls_id: int) -> int | None:
    """The process id of FLS ``fls_id``'s process under ``root``."""
    wanted = f"--fls-id\0{fls_id}\0".encode()
    for pid in swarm_pids(root)["fls"]:
        try:
            if wanted in Path(f"/proc/{pid}/cmdline").read_bytes():
                return pid
        except OSError:
            pass
    return None


def resident_mb(pid: int, field: str = "Rss:") -> float:
    """Resident memory of process ``pid``, MB: all of it (Rss) or its proportional share (Pss).

    Pss divides each page shared by n processes by n (the libraries every FLS
    process maps once for all): the sum of Pss over processes is what they
    take of the machine.
    """
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith(field):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def cpu_seconds(pids: list[int]) -> float:
    """User and system CPU seconds the processes have used so far."""
    tick = os.sysconf("SC_CLK_TCK")
    total = 0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        total += int(fields[11]) + int(fields[12])
    return total / tick


def available_mb() -> float:
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemAvailable:"):
            return int(line.split()[1]) / 1024.0
    return float("nan")


def compare_without(world: Any, result: Any, gone_ids: set[int]) -> dict[str, object]:
    """The swarm's estimates beside the engine's on the shape without ``gone_ids``."""
    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.core.evaluation import NO_PATH
    from swazure_ros.core.neighbourhood import without

    ids = world.ids
    gone_index = np.flatnonzero(np.isin(ids, sorted(gone_ids)))
    expected = evaluate_pairs(without(world.hood, gone_index), POLICY)
    found = {
        (source, one.target): one
        for source, some in result.outcome.estimates.items()
        for one in some
    }
    keep = ~np.isin(expected.source, gone_index) & ~np.isin(expected.target, gone_index)
    wrong = missing = 0
    for pair in np.flatnonzero(keep).tolist():
        source, target = int(ids[expected.source[pair]]), int(ids[expected.target[pair]])
        one = found.get((source, target))
        if one is None:
            missing += 1
            continue
        same = (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
        same = same and one.path == tuple(int(ids[k]) for k in expected.path(pair))
        if same and one.status != NO_PATH:
            same = bool(np.allclose(one.vector, expected.estimate[pair], rtol=0, atol=1e-9))
        wrong += not same
    return {
        "pairs": int(keep.sum()),
        "reported": len(found),
        "wrong": wrong,
        "missing": missing,
        "identical": wrong == 0 and missing == 0 and len(found) == int(keep.sum()),
    }


def fault_run(swarm: Any, root: Path, victims: list[int], kill_server: bool) -> dict[str, object]:
    """A discovery run in which ``victims``' processes (and the server) are killed mid-run."""
    coordinator = swarm.coordinator
    began = time.monotonic()
    killed_at: float | None = None
    detected_at: float | None = None

    def step() -> None:
        nonlocal killed_at, detected_at
        if killed_at is None and time.monotonic() - began > 0.5:
            for fls_id in victims:
                pid = fls_pid(root, fls_id)
                if pid is not None:
                    os.kill(pid, signal.SIGKILL)
            if kill_server:
                for process in swarm.discovery_servers.processes.values():
                    process.kill()
            killed_at = time.monotonic()
        if (
            killed_at is not None
            and detected_at is None
            and set(victims) <= coordinator.departed_so_far()
        ):
            detected_at = time.monotonic()

    result = swarm.run(coordinator.discover(POLICY), timeout=600, step=step)
    if detected_at is None and set(victims) <= set(result.outcome.departed):
        detected_at = time.monotonic()
    record = {
        "killed": victims,
        "server_killed": kill_server,
        "seconds": result.seconds,
        "restarts": result.outcome.restarts,
        "departed": sorted(result.outcome.departed),
        "detection_s": None
        if detected_at is None or killed_at is None
        else detected_at - killed_at,
    }
    record.update(
        compare_without(swarm.world, result, set(result.outcome.departed) | set(victims))
    )
    return record


def arguments() -> argparse.Namespace:
    """The command line: the swarm's size, hosts and discovery, the record's file, what to run."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--flss", type=int, required=True)
    parser.add_argument("--hosts", type=int, default=4)
    parser.add_argument("--discovery", choices=["simple", "server"], required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--compute-all", action="store_true")
    parser.add_argument("--faults", action="store_true")
    parser.add_argument("--idle", type=float, default=10.0, help="seconds of idle sampling")
    parser.add_argument("--timeout", type=float, default=420.0, help="bring-up deadline, s")
    return parser.parse_args()


def main() -> int:
    from swazure_ros.app.discovery_server import parse_servers
    from swazure_ros.app.swarm import RunningSwarm, Starting
    from swazure_ros.ros.security.keys import new_key, write_key

    args = arguments()
    record: dict[str, object] = {
        "flss": args.flss, "hosts": args.hosts, "discovery": args.discovery,
    }  # fmt: skip
    needed = args.flss * FLS_MB + 1500
    if available_mb() < needed:
        record["stopped"] = f"memory: {available_mb():.0f} MB available, {needed:.0f} MB needed"
        args.out.write_text(json.dumps(record, indent=1))
        return 0
    root = Path(tempfile.mkdtemp(prefix="swazure-hosts-"))
    key_file = root / "swarm.key"
    key = new_key()
    write_key(key_file, key)
    servers = parse_servers(address(0)) if args.discovery == "server" else ()
    sent_before = sent(args.hosts)
    began = time.monotonic()
    followers = start_followers(args, root, key_file, bool(servers))

    def failed(swarm: Starting, err: Exception) -> None:
        """The record says where the bring-up stopped, measured before the swarm stops."""
        record["stopped"] = f"bring-up: {err}"
        record.update(stopped_record(swarm, root, args.hosts, sent_before))

    try:
        config = leader_config(args, root, key, servers)
        with RunningSwarm.start(config, on_failed=failed) as swarm:
            bring_up = swarm.bring_up
            record["bring_up_s"] = time.monotonic() - began
            record.update(up_record(swarm, root, args, sent_before, bring_up.peak_rss_mb[0]))
            print(f"bench_hosts: {args.flss} FLSs, {args.discovery}: up in "
                  f"{record['bring_up_s']:.1f} s", file=sys.stderr, flush=True)  # fmt: skip
            if args.compute_all:
                record.update(computed_record(swarm))
            if args.faults:
                record.update(faults_record(swarm, root, args.flss, bool(servers)))
    except Exception as err:
        record.setdefault("stopped", f"{type(err).__name__}: {err}")
    finally:
        stop_followers(followers)
        args.out.write_text(json.dumps(record, indent=1))
    return 0


def spawn_arguments(args: argparse.Namespace, key_file: Path, server: bool) -> list[str]:
    """`swazure spawn`'s arguments for a host's share of the torus (without the share)."""
    # The other hosts wait longer than host 0: the leader's view decides, and their FLS
    # processes are still there when it gives up and measures.
    common = ["spawn", "--cloud", f"torus:{args.flss}", "--scale", str(SCALE), "--beta",
              str(BETA), "--per-fls", "--key-file", str(key_file), "--quiet",
              "--discovery-timeout", str(args.timeout + 300)]  # fmt: skip
    if server:
        common += ["--discovery-server", address(0)]
    return common


def start_followers(
    args: argparse.Namespace, root: Path, key_file: Path, server: bool
) -> list[subprocess.Popen[bytes]]:
    """Hosts 1..H-1's shares, each started on its host as a person would start it."""
    followers = []
    for index in range(1, args.hosts):
        share = ["--share", f"{index}/{args.hosts}", "--log-dir", str(root / f"h{index}")]
        with (root / f"launcher{index}.log").open("w") as log:
            command = [str(SCRIPT), "exec", str(index), *SWAZURE,
                       *spawn_arguments(args, key_file, server), *share]  # fmt: skip
            followers.append(subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=log))
    return followers


def stop_followers(followers: list[subprocess.Popen[bytes]]) -> None:
    """Stop the other hosts' launchers as Ctrl-C would, killing any that does not stop."""
    for follower in followers:
        follower.send_signal(signal.SIGINT)
    for follower in followers:
        try:
            follower.wait(timeout=60)
        except subprocess.TimeoutExpired:
            follower.kill()


def leader_config(
    args: argparse.Namespace, root: Path, key: bytes, servers: tuple[Any, ...]
) -> Any:
    """Host 0's share of the torus: the simulator, the coordinator and its FLS processes."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.sim.world import WorldSpec

    return SwarmConfig(
        WorldSpec(cloud=f"torus:{args.flss}", scale=SCALE, beta=BETA),
        share=0,
        hosts=args.hosts,
        per_fls=True,
        key=key,
        discovery_servers=servers,
        log_dir=str(root / "h0"),
        discovery_timeout=args.timeout,
    )


def everyone(swarm: Any, pids: dict[str, list[int]]) -> list[int]:
    """Every process of the swarm: this one, the launchers, the FLS processes, the servers."""
    servers = [p.pid for p in swarm.discovery_servers.processes.values()]
    return [os.getpid(), *pids["launchers"], *pids["fls"], *servers]


def stopped_record(
    swarm: Any, root: Path, hosts: int, sent_before: tuple[int, int]
) -> dict[str, object]:
    """A bring-up that did not end: who was unseen, what it had taken by then."""
    seen = {name for name, _ in swarm.host.host_node.get_node_names_and_namespaces()}
    pids = swarm_pids(root)
    packets1, bytes1 = sent(hosts)
    return {
        "unseen": [int(fls_id) for fls_id in swarm.world.ids if f"fls_{fls_id}" not in seen],
        "fls_processes": len(pids["fls"]),
        "total_pss_mb": sum(resident_mb(pid, "Pss:") for pid in everyone(swarm, pids)),
        "cpu_s": cpu_seconds(everyone(swarm, pids)),
        "stopped_packets": packets1 - sent_before[0],
        "stopped_bytes": bytes1 - sent_before[1],
    }


def up_record(
    swarm: Any,
    root: Path,
    args: argparse.Namespace,
    sent_before: tuple[int, int],
    launcher_peak_mb: float,
) -> dict[str, object]:
    """A swarm up: its bring-up CPU and traffic, then idle CPU, traffic and memory."""
    record: dict[str, object] = {"bring_up_cpu_s": cpu_seconds(everyone(swarm, swarm_pids(root)))}
    packets1, bytes1 = sent(args.hosts)
    record["bring_up_packets"] = packets1 - sent_before[0]
    record["bring_up_bytes"] = bytes1 - sent_before[1]
    pids = swarm_pids(root)
    cpu0, t0 = cpu_seconds(everyone(swarm, pids)), time.monotonic()
    swarm.spin(args.idle)
    cpu1, t1 = cpu_seconds(everyone(swarm, pids)), time.monotonic()
    packets2, bytes2 = sent(args.hosts)
    record["idle_cpu_cores"] = (cpu1 - cpu0) / (t1 - t0)
    record["idle_packets_per_s"] = (packets2 - packets1) / (t1 - t0)
    record["idle_bytes_per_s"] = (bytes2 - bytes1) / (t1 - t0)
    record.update(memory_record(swarm, pids))
    record["launcher_peak_mb"] = launcher_peak_mb
    return record


def memory_record(swarm: Any, pids: dict[str, list[int]]) -> dict[str, object]:
    """Resident memory of the FLS processes, launchers and servers; the total Pss of them all."""
    servers_pids = [p.pid for p in swarm.discovery_servers.processes.values()]
    fls_mb = [resident_mb(pid) for pid in pids["fls"]]
    launchers = [os.getpid(), *pids["launchers"]]
    launchers_mb = [resident_mb(pid) for pid in launchers]
    servers_mb = [resident_mb(pid) for pid in servers_pids]
    return {
        "fls_processes": len(fls_mb),
        "fls_rss_mb_mean": float(np.mean(fls_mb)) if fls_mb else None,
        "fls_rss_mb_max": float(np.max(fls_mb)) if fls_mb else None,
        "launchers_rss_mb": launchers_mb,
        "servers_rss_mb": servers_mb,
        "total_rss_mb": float(sum(fls_mb) + sum(launchers_mb) + sum(servers_mb)),
        "total_pss_mb": sum(
            resident_mb(pid, "Pss:") for pid in [*launchers, *pids["fls"], *servers_pids]
        ),
    }


def computed_record(swarm: Any) -> dict[str, object]:
    """Every blind pair computed by the swarm beside the engine: timings and identity."""
    from swazure_ros.app.compute import compute_all

    computed = compute_all(swarm, POLICY)
    distributed, comparison = computed.record.distributed, computed.record.comparison
    engine = computed.record.engine
    assert distributed is not None and engine is not None  # a run of the swarm's
    return {
        "discovery_s": distributed.seconds,
        "rounds": distributed.rounds,
        "restarts": distributed.restarts,
        "engine_s": computed.record.engine_seconds,
        "pairs": engine.pairs.blind_pairs,
        "identical": "-" if comparison is None else comparison.describe(),
    }


def faults_record(swarm: Any, root: Path, flss: int, server: bool) -> dict[str, object]:
    """5 % of the FLS processes killed mid-run; then the server, and who is gone after it."""
    rng = np.random.default_rng(5)
    count = math.ceil(0.05 * flss)
    victims = sorted(int(v) for v in rng.choice(swarm.world.ids, count, replace=False))
    record: dict[str, object] = {"fault_fls": fault_run(swarm, root, victims, kill_server=False)}
    if server:
        record["fault_server"] = fault_run(swarm, root, [], kill_server=True)
        # Whether the living stay in each other's graph with the server gone.
        swarm.spin(30.0)
        record["gone_30s_after_server"] = sorted(swarm.coordinator.membership.gone - set(victims))
    return record


if __name__ == "__main__":
    sys.exit(main())
