"""Clients of a running swarm for the soaks: pose queries, their answers, the swarm's counters."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from bench.common import resident_mb


def pose_client(
    domain: int, name: str, diagnostics: dict[str, dict[str, str]]
) -> tuple[Any, Any, Any, Any]:
    """A node on ``domain`` with a ready compute_pose client; /diagnostics fill ``diagnostics``.

    Returns (context, node, executor, client); :func:`close_client` ends them.
    """
    import rclpy.executors
    from diagnostic_msgs.msg import DiagnosticArray
    from swazure_interfaces.srv import ComputePose

    from swazure_ros.ros.plumbing.node import SwarmNode
    from swazure_ros.ros.plumbing.process import init_context

    context = init_context(domain)
    node = SwarmNode(name, context=context)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def on_diagnostics(array: DiagnosticArray) -> None:
        for status in array.status:
            diagnostics[status.name] = {value.key: value.value for value in status.values}

    node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
    client = node.create_client(ComputePose, "/swarm/coordinator/compute_pose")
    while not client.service_is_ready():
        executor.spin_once(timeout_sec=0.1)
    return context, node, executor, client


def close_client(context: Any, node: Any, executor: Any) -> None:
    """Hear the latest counts (sent every second when they change), then end the node."""
    for _ in range(40):
        executor.spin_once(timeout_sec=0.05)
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()


def soak_counts(
    samples: list[tuple[float, float]],
    figure: str,
    diagnostics: dict[str, dict[str, str]],
    dropped_only: bool = False,
) -> list[str]:
    """A soak's memory line and the swarm's /diagnostics counts (all, or the drops), as lines."""
    lines = [
        f"Swarm memory: {samples[0][1]:.0f} MB at the start, {samples[-1][1]:.0f} MB at the end "
        f"(max {max(m for _, m in samples):.0f} MB); figure docs/figures/{figure}.",
        "",
        "The swarm's counts on /diagnostics at the end (messages dropped, by reason):",
        "",
        "| node | counter | messages |",
        "| --- | --- | ---: |",
    ]
    for name, values in sorted(diagnostics.items()):
        for counter, value in sorted(values.items()):
            if not dropped_only or counter.startswith("dropped"):
                lines.append(f"| {name.split(': ')[-1].split(' ')[0]} | {counter} | {value} |")
    return lines


def ask_random_pairs(
    client: Any,
    executor: Any,
    world: Any,
    engine: Any,
    policy: str,
    seconds: float,
    pid: int,
    rng: Any,
) -> tuple[int, int, int, list[tuple[float, float]]]:
    """Ask compute_pose for random blind pairs one after another for ``seconds``.

    Each answer is compared with the engine's (status, path, vector to 1e-9).
    Returns (right, wrong, unanswered within 120 s, [(minute, resident MB of
    ``pid``)] every 30 s).
    """
    import numpy as np
    from swazure_interfaces.srv import ComputePose

    from swazure_ros.ros.convert.discovery import pose_estimate_from_message
    from swazure_ros.ros.plumbing.names import POLICY_CODES

    right = wrong = unanswered = 0
    began = time.monotonic()
    samples = [(0.0, resident_mb(pid))]
    next_sample = 30.0
    while time.monotonic() - began < seconds:
        row = int(rng.integers(len(engine)))
        source, target = int(world.ids[engine.source[row]]), int(world.ids[engine.target[row]])
        request = ComputePose.Request(
            source_id=source, target_id=target, policy=POLICY_CODES[policy]
        )
        asked = time.monotonic()
        future = client.call_async(request)
        while not future.done() and time.monotonic() - asked < 120:
            executor.spin_once(timeout_sec=0.05)
        if not future.done() or not future.result().success:
            unanswered += 1
        else:
            got = pose_estimate_from_message(future.result().estimate)
            path = tuple(int(world.ids[k]) for k in engine.path(row))
            same = (got.status, got.path) == (engine.status[row], path) and (
                got.status == 2 or np.allclose(got.vector, engine.estimate[row], rtol=0, atol=1e-9)
            )
            right, wrong = right + same, wrong + (not same)
        if time.monotonic() - began >= next_sample:
            samples.append(((time.monotonic() - began) / 60, resident_mb(pid)))
            next_sample += 30.0
    samples.append(((time.monotonic() - began) / 60, resident_mb(pid)))
    return right, wrong, unanswered, samples


def hostile_figure(
    samples: list[tuple[float, float]],
    path: Path,
    title: str = "chess_408 swarm under queries and a hostile peer's flood",
) -> None:
    """The swarm's memory over a soak, as a PNG."""
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    figure = Figure(figsize=(6.5, 3.6), layout="constrained")
    axes = figure.subplots()
    axes.plot([m for m, _ in samples], [r for _, r in samples], ".-")
    axes.set_xlabel("minute")
    axes.set_ylabel("resident memory of the swarm (MB)")
    axes.set_ylim(bottom=0)
    axes.grid(True, alpha=0.3)
    axes.set_title(title)
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
