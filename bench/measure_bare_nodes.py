"""What N bare rclpy processes on one host cost DDS: the floor under one process per FLS.

Starts a probe process that watches the ROS graph, then N processes that each
make one rclpy node and spin, nothing else (no topic of ours, no numpy, no
key), at the FLS processes' niceness (``app.per_fls.FLS_NICENESS``): how long
until the probe sees every node, and the CPU the N processes used
until then and over the next ``--idle`` seconds. By simple discovery, or
through a Fast DDS Discovery Server on this host (the probe a super client).
Whatever one process per FLS costs beyond this is ours; this much is the
middleware's on this machine. Every process takes the FLS processes' DDS
settings (``app.per_fls.FLS_ENVIRONMENT``'s UDP transport, and the swarm's
profile, ``ros.plumbing.participants``), unless the environment sets them.

    python -m bench.measure_bare_nodes --nodes 50 --discovery server --out record.json
"""

from __future__ import annotations

import argparse
import json
import os
import select
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench.measure_hosts import cpu_seconds
from swazure_ros.app.discovery_server import DiscoveryServers, client_environment, parse_servers
from swazure_ros.app.per_fls import FLS_ENVIRONMENT, FLS_NICENESS
from swazure_ros.core.errors import SwazureError
from swazure_ros.files.atomic import atomic_write
from swazure_ros.ros.plumbing import shared_memory
from swazure_ros.ros.plumbing.participants import profile_environment

#: One bare ROS 2 process: a node that spins until its parent's pipe closes.
NODE_PROGRAM = (
    # The pipe's end first: a process still making its participant ends with it too.
    "import os, sys, threading; "
    "threading.Thread(target=lambda: (os.read(0, 1), os._exit(0)), daemon=True).start(); "
    "import rclpy; rclpy.init(); rclpy.spin(rclpy.create_node(sys.argv[1]))"
)
#: The probe: prints, about once a second, how many of the bare nodes its graph shows.
PROBE_PROGRAM = """
import rclpy
rclpy.init()
probe = rclpy.create_node("bare_probe")
while True:
    rclpy.spin_once(probe, timeout_sec=1.0)
    names = probe.get_node_names_and_namespaces()
    print(sum(name.startswith("bare_") and name != "bare_probe" for name, _ in names), flush=True)
"""


def stop(children: list[subprocess.Popen[bytes]], patience: float = 30.0) -> int:
    """Close every child's pipe (it then exits), and kill those not gone ``patience`` s
    later, with their shared memory; how many were killed."""
    for child in children:
        assert child.stdin is not None
        child.stdin.close()
    deadline = time.monotonic() + patience
    killed = 0
    for child in children:
        try:
            child.wait(timeout=max(deadline - time.monotonic(), 0.1))
        except subprocess.TimeoutExpired:
            shared_memory.kill(child)
            killed += 1
    return killed


def watch(probe: subprocess.Popen[bytes], nodes: int, deadline: float) -> int:
    """The most bare nodes ``probe`` has seen, read until it sees ``nodes`` or the monotonic
    ``deadline`` passes (a probe starved of CPU, or stuck, cannot hold the run longer)."""
    assert probe.stdout is not None
    seen = 0
    while seen < nodes:
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([probe.stdout], [], [], left)[0]:
            break
        line = probe.stdout.readline()
        if not line:  # the probe ended
            break
        seen = max(seen, int(line))
    return seen


def measure(
    nodes: int, discovery: str, deadline: float, idle: float, gap: float = 0.0
) -> dict[str, object]:
    """One run: ``nodes`` bare processes, started ``gap`` s apart, and a probe; when the probe
    saw them all, and their CPU."""
    environment = {**FLS_ENVIRONMENT, **os.environ, **profile_environment()}
    servers = parse_servers("127.0.0.1") if discovery == "server" else ()
    logs = tempfile.TemporaryDirectory(prefix="bare-nodes-")
    started = DiscoveryServers(servers, Path(logs.name))
    probe: subprocess.Popen[bytes] | None = None
    children: list[subprocess.Popen[bytes]] = []
    try:
        started.start()
        # The probe first, as a launcher is up before its FLSs.
        probe_environment = dict(environment)
        if servers:
            probe_environment.update(client_environment(servers, super_client=True))
            environment.update(client_environment(servers, super_client=False))
        probe = subprocess.Popen(
            [sys.executable, "-c", PROBE_PROGRAM],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            env=probe_environment,
        )
        start = time.monotonic()
        for index in range(nodes):
            children.append(
                subprocess.Popen(
                    [sys.executable, "-c", NODE_PROGRAM, f"bare_{index}"],
                    stdin=subprocess.PIPE,
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env=environment,
                    preexec_fn=lambda: os.nice(FLS_NICENESS),
                )
            )
            time.sleep(gap)
        pids = [child.pid for child in children]
        seen = watch(probe, nodes, start + deadline)
        up = time.monotonic() - start if seen >= nodes else None
        cpu_up = cpu_seconds(pids) if up is not None else None
        probe.kill()
        probe.wait()
        assert probe.stdout is not None
        probe.stdout.close()
        before = cpu_seconds(pids)
        time.sleep(idle)
        idle_cores = (cpu_seconds(pids) - before) / idle
        killed = stop(children)
        children = []
    finally:
        # Interrupted (Ctrl-C, an error): leave no probe and no bare process running.
        if probe is not None and probe.poll() is None:
            probe.kill()
            probe.wait()
        stop(children, patience=5.0)
        started.stop()
        logs.cleanup()
    return {
        "nodes": nodes,
        "discovery": discovery,
        "up_seconds": up,
        "seen": seen,
        "cpu_seconds_until_up": cpu_up,
        "idle_cores": idle_cores,
        "killed": killed,
        "deadline": deadline,
        "gap": gap,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, required=True)
    parser.add_argument("--discovery", choices=["simple", "server"], required=True)
    parser.add_argument("--deadline", type=float, default=180.0, help="seconds to wait, at most")
    parser.add_argument("--idle", type=float, default=10.0, help="seconds of idle sampling")
    parser.add_argument("--gap", type=float, default=0.0, help="seconds between two starts")
    parser.add_argument("--out", type=Path, required=True, help="the record's JSON file")
    args = parser.parse_args()
    if not args.out.parent.is_dir():
        # Said before minutes of measuring, not after.
        parser.error(f"--out {args.out}: no folder {args.out.parent}")
    try:
        record = measure(args.nodes, args.discovery, args.deadline, args.idle, args.gap)
        atomic_write(args.out, lambda path: path.write_text(json.dumps(record, indent=1) + "\n"))
    except (SwazureError, OSError) as err:
        print(f"measure_bare_nodes: error: {err}", file=sys.stderr)
        return 1
    print(json.dumps(record))
    return 0


if __name__ == "__main__":
    sys.exit(main())
