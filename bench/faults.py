"""The dragon's distributed discovery under a lossy radio, killed FLSs, a lost coordinator.

The `faults` section of BENCHMARKS.md (`python -m bench --sections faults`).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path
from typing import Any

from bench.common import SECTIONS_DIR, swarm_cloud

POLICY = "shortest-length"
#: Every FLS's parameters: slow heartbeats, so that the runs' own messages are what counts.
BASE_PARAMS = "/**:\n  ros__parameters:\n    publish_period: 30.0\n"
RADIO_CASES = (
    ("perfect radio", ""),
    ("10 % of deliveries lost", "    radio:\n      loss: 0.1\n      seed: 7\n"),
    (
        "10 % lost, each message up to 50 ms late",
        "    radio:\n      loss: 0.1\n      seed: 7\n      delay: 0.05\n",
    ),
)


def faults_section(
    args: argparse.Namespace,
    shape: str = "dragon_1147",
    domain: int = 95,
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The dragon's distributed discovery under a lossy radio, killed FLSs, a lost coordinator."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    cloud = swarm_cloud(shape)
    lines = [
        "## Faults: the dragon's distributed discovery, beta 0.5, Shortest-Length",
        "",
        "One process (`RunningSwarm`), the whole swarm discovering every blind pair.",
        "",
        "| case | wall s | rounds | restarts | messages | radio repairs | result |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for label, extra in RADIO_CASES:
        with faulty_swarm(cloud, args.beta, domain, BASE_PARAMS + extra, records_dir) as running:
            lines.append(radio_row(running, label))
    # 5 % of the FLS nodes stopped once the run is under way, under a long round timeout.
    params = BASE_PARAMS + "/**/coordinator:\n  ros__parameters:\n    round_timeout: 600.0\n"
    with faulty_swarm(cloud, args.beta, domain, params, records_dir) as running:
        lines.append(stopped_row(running))
    with faulty_swarm(cloud, args.beta, domain, BASE_PARAMS, records_dir) as running:
        lines.append(lost_coordinator_row(running))
    return [*lines, ""]


def faulty_swarm(
    cloud: str, beta: float, domain: int, params: str, folder: Path = SECTIONS_DIR
) -> Any:
    """A RunningSwarm of ``cloud`` in this process under the parameters ``params`` (YAML)."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    path = folder / "faults.yaml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(params)
    world = WorldSpec(cloud, beta=beta)
    return RunningSwarm.start(SwarmConfig(world, domain_id=domain, params_file=str(path)))


def same(world: Any, result: Any, engine: Any, gone_index: Any = None) -> str:
    """How many of the engine's pairs (but those of ``gone_index``) the swarm found alike."""
    import numpy as np

    ids = world.ids
    found = {(s, one.target): one for s, e in result.outcome.estimates.items() for one in e}
    keep = np.ones(len(engine), bool)
    if gone_index is not None:
        keep = ~np.isin(engine.source, gone_index) & ~np.isin(engine.target, gone_index)
    differ = 0
    for pair in np.flatnonzero(keep).tolist():
        one = found.get((int(ids[engine.source[pair]]), int(ids[engine.target[pair]])))
        path = tuple(int(ids[k]) for k in engine.path(pair))
        if one is None or one.status != engine.status[pair] or one.path != path:
            differ += 1
    return f"{int(keep.sum()) - differ} of {int(keep.sum())} pairs identical"


def radio_row(running: Any, label: str) -> str:
    """One discovery under the swarm's radio: its table row."""
    from swazure_ros.core.evaluate import evaluate_pairs

    engine = evaluate_pairs(running.world.hood, POLICY)
    began = time.monotonic()
    result = running.discover(POLICY, timeout=1800)
    wall, run = time.monotonic() - began, result.outcome
    return (
        f"| {label} | {wall:.1f} | {run.rounds} | {run.restarts} "
        f"| {result.traffic.total_messages} | {run.repairs} "
        f"| {'INCOMPLETE' if run.incomplete else same(running.world, result, engine)} |"
    )


def stopped_row(running: Any) -> str:
    """A discovery with 5 % of the FLS nodes stopped once it is under way: its table row."""
    import numpy as np

    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.core.neighbourhood import without

    world = running.world
    gone_index = np.sort(
        np.random.default_rng(5).choice(len(world.ids), len(world.ids) // 20, replace=False)
    )
    gone = [int(world.ids[k]) for k in gone_index]
    watched = running.host.fls_by_id[gone[0]]
    stopped_at: list[float] = []

    def stop() -> None:
        if not stopped_at and watched.messages_sent >= 3:
            for fls in gone:
                running.host.stop_fls(fls)
            stopped_at.append(time.monotonic())

    began = time.monotonic()
    result = running.run(running.coordinator.discover(POLICY), timeout=1800, step=stop)
    wall, run = time.monotonic() - began, result.outcome
    expected = evaluate_pairs(without(world.hood, gone_index), POLICY)
    return (
        f"| {len(gone)} FLS nodes (5 %) stopped mid-run | {wall:.1f} | {run.rounds} "
        f"| {run.restarts} | {result.traffic.total_messages} | - "
        f"| departed {len(run.departed)}; {same(world, result, expected, gone_index)} "
        "(engine without them) |"
    )


def lost_coordinator_row(running: Any) -> str:
    """The coordinator lost mid-run: how long until every source has a status; its row."""
    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.core.evaluation import ABORTED
    from swazure_ros.ros.nodes.coordinator import Coordinator

    world = running.world
    pairs = len(evaluate_pairs(world.hood, POLICY))
    running.coordinator.discover(POLICY)
    relay = running.host.fls_nodes[0]
    while relay.messages_sent < 3:
        running.host.spin_once(0.02)
    running.host.remove(running.coordinator)
    began = time.monotonic()
    while running.host.aborted < pairs and time.monotonic() - began < 60:
        running.host.spin_once(0.02)
    until = time.monotonic() - began
    running.coordinator = Coordinator(
        world.ids.tolist(),
        hosts=1,
        shape=world.swarm,
        sensor=world.sensor,
        namespace="swarm",
        context=running.context,
        key=running.key,
    )
    running.host.add(running.coordinator)
    began = time.monotonic()
    again = running.discover(POLICY, timeout=1800)
    return (
        f"| coordinator lost mid-run | {until:.2f} | - | - | - | - "
        f"| {running.host.aborted} of {pairs} pairs ABORTED (status {ABORTED}) "
        f"{until:.2f} s after; a new coordinator's run {time.monotonic() - began:.1f} s: "
        f"{same(world, again, evaluate_pairs(world.hood, POLICY))} |"
    )
