"""Every published shape's swarm: bring-up, rest, message rate, teardown.

The `swarm` section of BENCHMARKS.md (`python -m bench --sections swarm`).
"""

from __future__ import annotations

import argparse
import os
import select
import subprocess
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import BRING_UP_LIMIT, SHAPE_SIZES, children, spawn_command, swarm_cloud


def message_rate(
    cloud: str, domain: int, period: float = 0.1, window: float = 10.0, processes: int = 1
) -> float:
    """Measurements messages per second a probe receives from a running swarm."""
    import rclpy.executors
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from swazure_interfaces.msg import Measurements

    from swazure_ros.ros.plumbing.node import SwarmNode
    from swazure_ros.ros.plumbing.process import init_context

    params = Path(tempfile.mkstemp(suffix=".yaml")[1])
    # A swarm at rest sends nothing: the heartbeat makes every FLS send every period.
    params.write_text(
        f"/**:\n  ros__parameters:\n    publish_period: {period}\n    republish_period: {period}\n"
    )
    command = spawn_command(cloud, domain, "--params", str(params), "--processes", str(processes))
    process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
    try:
        assert process.stdout is not None
        process.stdout.readline()  # "swarm up ..."
        context = init_context(domain)
        node: Any = SwarmNode("bench_probe", context=context)
        count = 0

        def on_message(message: object) -> None:
            nonlocal count
            count += 1

        qos = QoSProfile(
            depth=1000,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
        node.create_subscription(Measurements, "/swarm/measurements", on_message, qos)
        executor = rclpy.executors.SingleThreadedExecutor(context=context)
        executor.add_node(node)
        settle = time.monotonic() + 3.0
        while time.monotonic() < settle:
            executor.spin_once(timeout_sec=0.01)
        count = 0
        began = time.monotonic()
        while time.monotonic() - began < window:
            executor.spin_once(timeout_sec=0.01)
        rate = count / (time.monotonic() - began)
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()
        return rate
    finally:
        process.terminate()
        process.wait(timeout=120)
        if process.stdout is not None:
            process.stdout.close()
        params.unlink()


def served(cloud: str, processes: int, domain: int, window: float = 20.0) -> dict[str, object]:
    """Serve a swarm at rest: its bring-up line, idle CPU % of one core, teardown s.

    The CPU is every process of `swazure spawn` over ``window`` s once up (from
    /proc); teardown is from SIGTERM until the launcher has exited.
    """
    out = Path(tempfile.mkdtemp(prefix="bench-served-"))
    command = spawn_command(cloud, domain, "--processes", str(processes), "--out", str(out))
    began = time.monotonic()
    process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
    ticks = os.sysconf("SC_CLK_TCK")

    def cpu_seconds() -> float:
        # Every process of the swarm: the launcher and its children.
        total = 0.0
        for pid in [process.pid, *children(process.pid)]:
            with open(f"/proc/{pid}/stat") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
            total += (int(fields[11]) + int(fields[12])) / ticks
        return total

    row: dict[str, object] = {}
    try:
        assert process.stdout is not None
        ready = select.select([process.stdout], [], [], BRING_UP_LIMIT)[0]
        line = process.stdout.readline() if ready else ""
        if not line.startswith("swarm up:"):
            row["failed"] = (
                f"not up in {BRING_UP_LIMIT / 60:.0f} min" if not ready else f"failed: {line}"
            )
            return row
        row["wall_up"] = time.monotonic() - began
        from swazure_ros.files.record import RECORD_FILE, read_record

        bring_up = read_record(out / RECORD_FILE).bring_up
        assert bring_up is not None
        row["discovered"] = bring_up.seconds
        peaks = " + ".join(f"{mb:.0f}" for mb in bring_up.peak_rss_mb)
        row["memory"] = f"{bring_up.total_peak_mb:.0f} MB ({peaks})"
        time.sleep(5.0)
        before, sampled = cpu_seconds(), time.monotonic()
        time.sleep(window)
        row["idle"] = 100.0 * (cpu_seconds() - before) / (time.monotonic() - sampled)
    finally:
        stopped = time.monotonic()
        process.terminate()
        process.wait(timeout=900)
        if process.stdout is not None:
            process.stdout.close()
        row["teardown"] = time.monotonic() - stopped
    return row


def swarm_section(
    args: argparse.Namespace,
    sizes: dict[str, int] = SHAPE_SIZES,
    domain: int = 91,
    processes: Sequence[int] = (1, 2),
    window: float = 20.0,
) -> list[str]:
    """Every published shape's swarm: bring-up, rest, message rate, teardown.

    ``window``: seconds of the idle CPU's sampling (the message rate's, half of it).
    """
    lines = [
        "## The swarm on ROS 2: `swazure spawn`, one node per FLS, beta 0.5",
        "",
        "Each row is one served swarm with the default parameters (config/swarm.yaml: a",
        "measurement is sent when it changes). Discovered: from launcher start until every",
        "process sees every FLS node's publisher and service. Peak memory per process. Idle",
        "CPU: every process over 20 s once up, in % of one core. Teardown: from SIGTERM until",
        "the launcher has exited.",
        "",
        "| shape | FLS nodes | processes | discovered s | peak MB (per process) "
        "| idle CPU % | teardown s |",
        "| --- | ---: | ---: | ---: | --- | ---: | ---: |",
    ]
    for name, flss in sizes.items():
        for count in processes:
            row = served(swarm_cloud(name), count, domain, window)
            print(f"served {name} x{count}: {row}", flush=True)
            lines.append(served_row(name, flss, count, row))
    lines += [
        "",
        "Messages delivered once up: every FLS is set to publish its Measurements every 0.1 s",
        "on the shared topic (a heartbeat: republish_period 0.1 s); a probe node in another",
        "process counts what arrives over 10 s. One process (two for the race car). A process",
        "sends what its core can build: the large shapes' messages hold hundreds of poses.",
        "",
        "| shape | FLS nodes | processes | asked per s (heartbeat) | received per s |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for name, flss in sizes.items():
        count = 2 if flss > 2000 else 1
        rate = message_rate(swarm_cloud(name), domain, window=window / 2, processes=count)
        print(f"rate {name}: {rate:.0f} msg/s", flush=True)
        lines.append(f"| {name} | {flss} | {count} | {flss / 0.1:,.0f} | {rate:,.0f} |")
    lines += [
        "",
        "Targets (issue 16): the race car's 3720 nodes up in under 60 s, under 4 GB; the",
        "dragon under 10 s, its teardown under 5 s, at rest under 25 % of one core.",
        "",
    ]
    return lines


def served_row(name: str, flss: int, processes: int, row: dict[str, Any]) -> str:
    """One served swarm's row: bring-up, memory, idle CPU and teardown, or why it failed."""
    if "failed" in row:
        return f"| {name} | {flss} | {processes} | {row['failed']} | | | {row['teardown']:.1f} |"
    return (
        f"| {name} | {flss} | {processes} | {row['discovered']:.1f} | {row['memory']} "
        f"| {row['idle']:.1f} | {row['teardown']:.1f} |"
    )
