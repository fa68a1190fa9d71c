"""Radio cells: what each packed process of a swarm hears, spends and matches in one discovery.

Runs one swarm (``--cloud``, ``--processes``) in this process and its further
shares (app.swarm.RunningSwarm), as ``swazure spawn --compute-all`` does, and
writes one JSON record (--out): per process, the FLSs it hosts, the radio
cells it subscribes to (from the ROS graph, as anyone sees them), the offers
it heard over DDS (its guard's counts on /diagnostics), its CPU seconds
during discovery (/proc), and the swarm's discovery time, the engine's time
for the same work and whether the pairs are the engine's. The bench's
``cells`` section runs it for each shape and process count.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.node import Node

from bench.common import record_file
from swazure_ros.app.compute import compute_all
from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.share import shares
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.observe import observations
from swazure_ros.files.atomic import atomic_write
from swazure_ros.protocol.loops import discover
from swazure_ros.ros.plumbing.names import RADIO_TOPIC, host_name
from swazure_ros.sim.world import WorldSpec

POLICY = "shortest-length"
TICKS = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid: int) -> float:
    """User and system CPU seconds process ``pid`` has spent so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def peak_mb(pid: int) -> float:
    """The peak resident memory of process ``pid`` so far, MB (VmHWM)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def arguments() -> argparse.Namespace:
    """The command line: the cloud, beta, processes, domain and the record's file."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cloud", required=True)
    parser.add_argument("--beta", type=float, default=0.5)
    parser.add_argument("--processes", type=int, default=1)
    parser.add_argument("--domain-id", type=int, default=93)
    parser.add_argument("--out", type=Path, required=True, help="the record's JSON file")
    args = parser.parse_args()
    record_file(parser, args)
    return args


def main() -> int:
    args = arguments()
    spec = WorldSpec(args.cloud, beta=args.beta)
    # As `spawn --compute-all` of plain Swazure: the launcher holds its own FLSs' pairs, and
    # the comparison with the engine goes block by block (app.compute).
    config = SwarmConfig(
        spec, processes=args.processes, domain_id=args.domain_id, whole_world=False
    )
    # The engine's and the search's compiled kernels loaded (compiled, after a change of
    # their source) before either is timed: a second or two that is not the run's.
    small = WorldSpec("torus:120", scale=1.6, beta=args.beta).build()
    evaluate(small.swarm, small.sensor, POLICY)
    discover(observations(small.hood), small.ids, small.sensor, small.swarm.radius, POLICY)
    began = time.perf_counter()
    print(
        f"bench_cells: bringing up {args.cloud} over {args.processes}", file=sys.stderr, flush=True
    )
    with RunningSwarm.start(config) as swarm:
        bring_up = swarm.bring_up
        up = time.perf_counter() - began
        first, live = swarm.first_block()
        print(f"bench_cells: up in {up:.0f} s; discovering, {len(first)} of {len(live)} "
              "sources in the first run", file=sys.stderr, flush=True)  # fmt: skip
        heard = heard_offers(swarm)
        pids = swarm.process_ids
        cpu_before = [cpu_seconds(pid) for pid in pids]
        computed = compute_all(swarm, POLICY)
        cpu = [cpu_seconds(pid) - before for pid, before in zip(pids, cpu_before, strict=True)]
        peaks = [peak_mb(pid) for pid in pids]
        swarm.spin(2.5)  # every process's counts reach /diagnostics
        radio, cells = radio_cells(swarm, config.namespace)
        record = computed.record
        distributed = record.distributed
        assert distributed is not None
        sizes = [len(share) for share in shares(spec.assigned(), args.processes)]
        out = {
            "cloud": args.cloud,
            "flss": swarm.size,
            "processes": args.processes,
            "bring_up_s": up,
            "peak_mb": bring_up.total_peak_mb,
            "discovery_s": distributed.seconds,
            "rounds": distributed.rounds,
            "source_runs": distributed.runs,
            "engine_s": record.engine_seconds,
            "identical": "-" if record.comparison is None else record.comparison.describe(),
            "radio_messages": distributed.messages.get(RADIO_TOPIC, 0),
            "radio_bytes": distributed.bytes.get(RADIO_TOPIC, 0),
            "radio_topics": len(radio),
            "per_process": [
                {
                    "flss": sizes[index],
                    "cells": cells.get(host_name(index), 0),
                    "offers_over_dds": heard.get(host_name(index), {}).get("offers", 0),
                    "bytes_over_dds": heard.get(host_name(index), {}).get("bytes", 0),
                    "cpu_s": cpu[index],
                    "peak_mb": peaks[index],
                }
                for index in range(args.processes)
            ],
        }
        assert swarm.host is not None and swarm.host.radio is not None
        out["per_process"][0]["offers_here"] = swarm.host.radio.offers_here
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, lambda path: path.write_text(json.dumps(out, indent=1)))
    print(json.dumps(out))
    return 0


def heard_offers(swarm: RunningSwarm) -> dict[str, dict[str, int]]:
    """Offers each process accepted over DDS and the bytes of those it heard, by host name,
    kept up to date from /diagnostics."""
    heard: dict[str, dict[str, int]] = {}

    def on_diagnostics(array: DiagnosticArray) -> None:
        for status in array.status:
            heard[status.hardware_id.rsplit("/", 1)[-1]] = {
                "offers": _summed(status, f"accepted {RADIO_TOPIC}/"),
                "bytes": _summed(status, f"heard bytes {RADIO_TOPIC}/"),
            }

    assert swarm.host is not None
    probe = Node("bench_cells", context=swarm.context, enable_rosout=False)
    probe.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 100)
    swarm.host.add(probe)
    return heard


def _summed(status: DiagnosticStatus, prefix: str) -> int:
    """The sum of ``status``'s counts whose keys start with ``prefix``."""
    return sum(int(one.value) for one in status.values if one.key.startswith(prefix))


def radio_cells(swarm: RunningSwarm, namespace: str) -> tuple[list[str], dict[str, int]]:
    """The radio cells' topics, and how many of them each process reads."""
    assert swarm.host is not None
    node = swarm.host.host_node
    radio = [
        topic
        for topic, _ in node.get_topic_names_and_types()
        if topic.startswith(f"/{namespace}/{RADIO_TOPIC}/")
    ]
    cells: dict[str, int] = {}
    for topic in radio:
        for reader in node.get_subscriptions_info_by_topic(topic):
            cells[reader.node_name] = cells.get(reader.node_name, 0) + 1
    return radio, cells


if __name__ == "__main__":
    sys.exit(main())
