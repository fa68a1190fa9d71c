"""A swarm under valid queries while scripts/hostile_peer.py floods every topic.

The `hostile` section of BENCHMARKS.md (`python -m bench --sections hostile`).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

from bench.clients import ask_random_pairs, close_client, hostile_figure, pose_client, soak_counts
from bench.common import REPO, spawn_command, swarm_cloud

#: How long the hostile-peer soak runs, s; SWAZURE_HOSTILE_SECONDS for a shorter try.
HOSTILE_SECONDS = float(os.environ.get("SWAZURE_HOSTILE_SECONDS", 600))


def signing_costs(shape: str = "dragon_1147", count: int = 2000) -> list[str]:
    """What the swarm's key costs per message: sign and check beside plain (de)serialisation.

    Each message timed ``count`` times; a round's cost for the swarm of ``shape``.
    """
    import timeit

    from rclpy.serialization import deserialize_message, serialize_message
    from swazure_interfaces.msg import PathOffer, PoseEstimates

    from swazure_ros.ros.security.auth import SwarmKey, new_key
    from swazure_ros.sim.world import WorldSpec

    key = SwarmKey(new_key())

    def offer(labels: int) -> PathOffer:
        return PathOffer(
            source_ids=list(range(labels)), hops=[2] * labels, lengths=[13.0] * labels,
            errors=[0.5] * labels, vectors=[1.5] * (3 * labels),
            path_offsets=list(range(0, 3 * labels + 1, 3)), path_ids=[7] * (3 * labels),
        )  # fmt: skip

    def estimates(count: int) -> PoseEstimates:
        return PoseEstimates(
            target_ids=list(range(count)), statuses=[0] * count, reasons=[0] * count,
            estimators=[0] * count, path_offsets=list(range(0, 3 * count + 1, 3)),
            path_ids=[7] * (3 * count), radio_path_offsets=list(range(0, 3 * count + 1, 3)),
            radio_path_ids=[7] * (3 * count), vectors=[1.5] * (3 * count),
            path_lengths=[13.0] * count, predicted_errors=[0.1] * count,
            covariances=[float("nan")] * (9 * count),
        )  # fmt: skip

    cases = [
        ("PathOffer, 1 label", offer(1)),
        ("PathOffer, 30 labels", offer(30)),
        ("PathOffer, 300 labels", offer(300)),
        ("PoseEstimates, 30 estimates", estimates(30)),
    ]
    lines = [
        "| message | bytes | serialise us | sign + serialise us | deserialise us "
        "| deserialise + check us |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]

    def per_call(call: Callable[[], object]) -> float:
        return timeit.timeit(call, number=count) / count * 1e6

    for name, message in cases:
        data, kind = key.serialize(message), type(message)
        plain = per_call(partial(serialize_message, message))
        signed = per_call(partial(key.serialize, message))
        read = per_call(partial(deserialize_message, data, kind))
        # verify, not deserialize: its cache would remember these very bytes.
        checked = per_call(lambda: key.verify(deserialize_message(data, kind)))  # noqa: B023
        lines.append(
            f"| {name} | {len(data):,} | {plain:.1f} | {signed:.1f} | {read:.1f} | {checked:.1f} |"
        )
    # Per round of the dragon: every FLS sends one offer, every process checks every one.
    dragon = WorldSpec(swarm_cloud(shape), beta=0.5).build()
    flss = len(dragon.ids)
    one_label = offer(1)
    check = timeit.timeit(
        lambda: key.verify(deserialize_message(key.serialize(one_label), PathOffer)), number=500
    )
    lines += [
        "",
        f"A round of the dragon ({flss} FLSs, one process) signs {flss} offers and checks "
        f"them at the radio and the coordinator: about {2 * flss * check / 500 * 1000:.0f} ms "
        "of a round's work for one-label offers.",
    ]
    return lines


def hostile_section(
    args: argparse.Namespace,
    shape: str = "chess_408",
    domain: int = 93,
    seconds: float = HOSTILE_SECONDS,
    figures: Path = REPO / "docs" / "figures",
    cost_shape: str = "dragon_1147",
) -> list[str]:
    """A swarm under valid queries while scripts/hostile_peer.py floods every topic."""
    soak = hostile_soak(swarm_cloud(shape), args.beta, domain, seconds)
    if soak is None:
        return ["## Hostile peers", "", "the chess swarm did not come up", ""]
    answers, samples, diagnostics, peer_report = soak
    hostile_figure(samples, figures / "hostile-soak.png")
    lines = hostile_lines(seconds, answers, peer_report, samples, diagnostics)
    return [*lines, "", "### What the key costs", "", *signing_costs(cost_shape), ""]


def hostile_soak(
    cloud: str, beta: float, domain: int, seconds: float
) -> tuple[tuple[int, int, int], list[tuple[float, float]], dict[str, Any], dict[str, int]] | None:
    """Queries of a spawned swarm for ``seconds`` while a hostile peer floods its topics.

    Right, wrong and unanswered queries, the memory samples, the swarm's diagnostics and
    what the peer sent by topic; None when the swarm does not come up.
    """
    import numpy as np

    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    world = WorldSpec(cloud, beta=beta).build()
    engine = evaluate_pairs(world.hood, policy)
    rng = np.random.default_rng(0)
    diagnostics: dict[str, dict[str, str]] = {}
    peer_report: dict[str, int] = {}
    # The with closes the swarm's pipe once it has stopped.
    with subprocess.Popen(
        spawn_command(cloud, domain), stdout=subprocess.PIPE, text=True
    ) as swarm:
        try:
            assert swarm.stdout is not None
            if not swarm.stdout.readline().startswith("swarm up:"):
                return None
            context, node, executor, client = pose_client(domain, "bench_hostile", diagnostics)
            peer = subprocess.Popen(
                [sys.executable, str(REPO / "scripts" / "hostile_peer.py"), str(domain),
                 str(seconds)],
                stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
            )  # fmt: skip

            right, wrong, unanswered, samples = ask_random_pairs(
                client, executor, world, engine, policy, seconds, swarm.pid, rng
            )
            out, _ = peer.communicate(timeout=120)
            peer_report = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
            close_client(context, node, executor)
        finally:
            swarm.terminate()
            swarm.wait(timeout=300)
    return (right, wrong, unanswered), samples, diagnostics, peer_report


def hostile_lines(
    seconds: float,
    answers: tuple[int, int, int],
    peer_report: dict[str, int],
    samples: list[tuple[float, float]],
    diagnostics: dict[str, dict[str, str]],
) -> list[str]:
    """The hostile soak's section (but the key's costs) from its queries and counters."""
    right, wrong, unanswered = answers
    sent = sum(peer_report.values())
    lines = [
        f"## Hostile peers: a swarm under valid queries and a flood of forged and malformed "
        f"messages for {seconds / 60:.0f} minutes",
        "",
        "`swazure spawn` of chess_408 (beta 0.5, one process, a fresh swarm key); a client asks",
        "`/swarm/coordinator/compute_pose` for random blind pairs (seeded) one after another and",
        "compares each answer with the engine's (status, path, vector to 1e-9); meanwhile",
        "`scripts/hostile_peer.py` publishes on every topic of the swarm messages generated",
        "from each type's fields (half unsigned, half under a key of its own) and, every time,",
        "a forged offer for the live run (sender FLS 1, a path over the blind pair 0-1, vector",
        "[123, 456, 789]). docs/security.md says what each check stops.",
        "",
        f"Valid queries: {right + wrong + unanswered}: {right} right, {wrong} wrong, "
        f"{unanswered} unanswered within 120 s.",
        f"Hostile messages sent: {sent:,} ("
        + ", ".join(f"{topic} {count:,}" for topic, count in sorted(peer_report.items()))
        + ").",
        *soak_counts(samples, "hostile-soak.png", diagnostics),
    ]
    return lines
