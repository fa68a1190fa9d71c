"""A chess swarm answering pose queries without pause: memory and endpoints over time.

The `soak` section of BENCHMARKS.md (`python -m bench --sections soak`).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import time
from pathlib import Path
from typing import Any

from bench.common import REPO, resident_mb, spawn_command, swarm_cloud

#: How long the soak runs, s; SWAZURE_SOAK_SECONDS for a shorter try.
SOAK_SECONDS = float(os.environ.get("SWAZURE_SOAK_SECONDS", 1800))


def soak_section(
    args: argparse.Namespace,
    shape: str = "chess_408",
    domain: int = 94,
    seconds: float = SOAK_SECONDS,
    figures: Path = REPO / "docs" / "figures",
) -> list[str]:
    """A chess swarm answering pose queries without pause: memory and endpoints over time."""
    run = soak_run(swarm_cloud(shape), args.beta, domain, seconds)
    if run is None:
        return ["## Soak", "", "the chess swarm did not come up", ""]
    samples, latencies, failures = run
    soak_figure(samples, figures / "soak.png")
    return soak_lines(samples, latencies, failures, seconds)


def soak_run(
    cloud: str, beta: float, domain: int, seconds: float
) -> tuple[list[dict[str, float]], list[float], list[str]] | None:
    """Random blind pairs asked of a spawned swarm for ``seconds``: samples, latencies, failures.

    A sample a minute (and one at each end) of the swarm's memory and the ROS graph's counts;
    None when the swarm does not come up.
    """
    import numpy as np

    from swazure_ros.core.neighbourhood import neighbourhood
    from swazure_ros.core.sensor import BLIND
    from swazure_ros.sim.world import WorldSpec

    world = WorldSpec(cloud, beta=beta).build()
    pairs = neighbourhood(world.swarm, world.sensor).pairs
    blind = np.flatnonzero(pairs.range_class == BLIND)
    rng = np.random.default_rng(0)
    samples: list[dict[str, float]] = []
    latencies: list[float] = []
    failures: list[str] = []
    # The with closes the swarm's pipe once it has stopped.
    with subprocess.Popen(
        spawn_command(cloud, domain), stdout=subprocess.PIPE, text=True
    ) as process:
        try:
            assert process.stdout is not None
            if not process.stdout.readline().startswith("swarm up:"):
                return None
            context, node, executor, client = soak_client(domain)

            def sample(elapsed: float) -> None:
                rss = resident_mb(process.pid)
                topics = node.get_topic_names_and_types()
                samples.append({
                    "minute": elapsed / 60, "rss": rss, "answered": len(latencies),
                    "failed": len(failures), "nodes": len(node.get_node_names()),
                    "publishers": sum(node.count_publishers(t) for t, _ in topics),
                    "subscriptions": sum(node.count_subscribers(t) for t, _ in topics),
                    "services": len(node.get_service_names_and_types()),
                })  # fmt: skip

            began = time.monotonic()
            sample(0.0)
            next_sample = 60.0
            while time.monotonic() - began < seconds:
                pair = int(rng.choice(blind))
                source, target = (
                    int(world.ids[pairs.first[pair]]),
                    int(world.ids[pairs.second[pair]]),
                )
                latency = asked_pose(client, executor, source, target)
                if latency is not None:
                    latencies.append(latency)
                else:
                    failures.append(f"{source}->{target}")
                if time.monotonic() - began >= next_sample:
                    sample(time.monotonic() - began)
                    next_sample += 60.0
            sample(time.monotonic() - began)
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
        finally:
            process.terminate()
            process.wait(timeout=300)
    return samples, latencies, failures


def soak_client(domain: int) -> tuple[Any, Any, Any, Any]:
    """A client node of the coordinator's compute_pose on ``domain``, once the service is up."""
    import rclpy.executors
    from swazure_interfaces.srv import ComputePose

    from swazure_ros.ros.plumbing.node import SwarmNode
    from swazure_ros.ros.plumbing.process import init_context

    context = init_context(domain)
    node = SwarmNode("bench_soak", context=context)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)
    client = node.create_client(ComputePose, "/swarm/coordinator/compute_pose")
    while not client.service_is_ready():
        executor.spin_once(timeout_sec=0.1)
    return context, node, executor, client


def asked_pose(client: Any, executor: Any, source: int, target: int) -> float | None:
    """The latency of one compute_pose of ``source`` -> ``target``, s; None if not answered."""
    from swazure_interfaces.srv import ComputePose

    from swazure_ros.ros.plumbing.names import POLICY_CODES

    request = ComputePose.Request(
        source_id=source, target_id=target, policy=POLICY_CODES["shortest-length"]
    )
    asked = time.monotonic()
    future = client.call_async(request)
    while not future.done() and time.monotonic() - asked < 60:
        executor.spin_once(timeout_sec=0.05)
    if future.done() and future.result().success:
        return time.monotonic() - asked
    return None


def soak_lines(
    samples: list[dict[str, float]], latencies: list[float], failures: list[str], seconds: float
) -> list[str]:
    """The soak's section from its samples, latencies (s) and failed pairs."""
    import numpy as np

    first, last = samples[0], samples[-1]
    lines = [
        f"## Soak: a chess swarm answering queries for {seconds / 60:.0f} minutes",
        "",
        "`swazure spawn` of chess_408 (beta 0.5, one process); a client asks",
        "`/swarm/coordinator/compute_pose` for random blind pairs (seeded), one after another,",
        "each a discovery run of its own. Memory is the resident set of every process of the",
        "swarm; endpoints are what the ROS graph shows (the client's own included).",
        "",
        f"Queries answered: {len(latencies)}, failed or unanswered within 60 s: {len(failures)}"
        + (f" ({', '.join(failures[:5])})" if failures else "")
        + ".",
        f"Latency: median {1000 * np.median(latencies):.0f} ms, 95th percentile "
        f"{1000 * np.percentile(latencies, 95):.0f} ms, max {1000 * max(latencies):.0f} ms."
        if latencies
        else "Latency: no query answered.",
        "",
        "| minute | answered | failed | memory (MB) | nodes | publishers | subscriptions "
        "| services |",
        "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    step = max(1, len(samples) // 12)
    shown = [row for row in samples[:-1:step] if row["minute"] < last["minute"] - 0.05]
    for row in [*shown, last]:
        lines.append(
            f"| {row['minute']:.1f} | {row['answered']:.0f} | {row['failed']:.0f} "
            f"| {row['rss']:.0f} | {row['nodes']:.0f} | {row['publishers']:.0f} "
            f"| {row['subscriptions']:.0f} | {row['services']:.0f} |"
        )
    growth = last["rss"] - first["rss"]
    flat = all(
        first[key] == last[key] for key in ("nodes", "publishers", "subscriptions", "services")
    )
    lines += [
        "",
        f"Memory from start to end: {first['rss']:.0f} -> {last['rss']:.0f} MB "
        f"({growth:+.0f} MB); endpoint counts {'unchanged' if flat else 'CHANGED'}. "
        "Figure: docs/figures/soak.png.",
        "",
    ]
    return lines


def soak_figure(samples: list[dict[str, float]], path: Path) -> None:
    """Memory and answered queries over the soak, as a PNG."""
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    minutes = [row["minute"] for row in samples]
    figure = Figure(figsize=(9.0, 3.8), layout="constrained")
    memory, answered = figure.subplots(1, 2)
    memory.plot(minutes, [row["rss"] for row in samples], ".-")
    memory.set_xlabel("minute")
    memory.set_ylabel("resident memory of the swarm (MB)")
    memory.set_ylim(bottom=0)
    memory.grid(True, alpha=0.3)
    answered.plot(minutes, [row["answered"] for row in samples], ".-", label="answered")
    answered.plot(minutes, [row["failed"] for row in samples], ".-", label="failed")
    answered.set_xlabel("minute")
    answered.set_ylabel("queries (cumulative)")
    answered.grid(True, alpha=0.3)
    answered.legend()
    figure.suptitle("Soak: chess_408 swarm under continuous compute_pose queries")
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
