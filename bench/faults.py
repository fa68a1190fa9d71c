"""The dragon's distributed discovery under a lossy radio, killed FLSs, a lost coordinator.

The `faults` section of BENCHMARKS.md (`python -m bench --sections faults`).
"""

from __future__ import annotations

import argparse
import os
import time

from bench.common import SECTIONS_DIR, swarm_cloud


def faults_section(args: argparse.Namespace) -> list[str]:
    """The dragon's distributed discovery under a lossy radio, killed FLSs, a lost coordinator."""
    import numpy as np

    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.core.evaluate import ABORTED, evaluate_pairs, without
    from swazure_ros.ros.coordinator import Coordinator
    from swazure_ros.sim.world import WorldSpec

    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    policy, cloud = "shortest-length", swarm_cloud("dragon_1147")
    lines = [
        "## Faults: the dragon's distributed discovery, beta 0.5, Shortest-Length",
        "",
        "One process (`RunningSwarm`), the whole swarm discovering every blind pair.",
        "",
        "| case | wall s | rounds | restarts | messages | radio repairs | result |",
        "| --- | ---: | ---: | ---: | ---: | ---: | --- |",
    ]

    def swarm(params: str) -> RunningSwarm:
        path = SECTIONS_DIR / "faults.yaml"
        path.write_text(params)
        world = WorldSpec(cloud, beta=args.beta)
        return RunningSwarm(SwarmConfig(world, domain_id=95, params_file=str(path)))

    def same(world, result, engine, gone_index=None) -> str:
        ids = world.ids
        found = {(s, one.target): one for s, e in result.estimates.items() for one in e}
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

    base = "/**:\n  ros__parameters:\n    publish_period: 30.0\n"
    for label, extra in (
        ("perfect radio", ""),
        ("10 % of deliveries lost", "    radio:\n      loss: 0.1\n      seed: 7\n"),
        (
            "10 % lost, each message up to 50 ms late",
            "    radio:\n      loss: 0.1\n      seed: 7\n      delay: 0.05\n",
        ),
    ):
        with swarm(base + extra) as running:
            running.wait_until_ready()
            engine = evaluate_pairs(running.world.hood, policy)
            began = time.monotonic()
            result = running.discover(policy, timeout=1800)
            wall = time.monotonic() - began
            lines.append(
                f"| {label} | {wall:.1f} | {result.rounds} | {result.restarts} "
                f"| {result.traffic.total_messages} | {result.repairs} "
                f"| {'INCOMPLETE' if result.incomplete else same(running.world, result, engine)} |"
            )
    # 5 % of the FLS nodes stopped once the run is under way, under a long round timeout.
    params = base + "/**/coordinator:\n  ros__parameters:\n    round_timeout: 600.0\n"
    with swarm(params) as running:
        running.wait_until_ready()
        world = running.world
        gone_index = np.sort(
            np.random.default_rng(5).choice(len(world.ids), len(world.ids) // 20, replace=False)
        )
        gone = [int(world.ids[k]) for k in gone_index]
        watched = running.host.fls_by_id[gone[0]]
        stopped_at = []

        def stop() -> None:
            if not stopped_at and watched.messages_sent >= 3:
                for fls in gone:
                    running.host.stop_fls(fls)
                stopped_at.append(time.monotonic())

        began = time.monotonic()
        result = running.run(running.coordinator.discover(policy), timeout=1800, step=stop)
        wall = time.monotonic() - began
        expected = evaluate_pairs(without(world.hood, gone_index), policy)
        lines.append(
            f"| {len(gone)} FLS nodes (5 %) stopped mid-run | {wall:.1f} | {result.rounds} "
            f"| {result.restarts} | {result.traffic.total_messages} | - "
            f"| departed {len(result.departed)}; {same(world, result, expected, gone_index)} "
            "(engine without them) |"
        )
    # The coordinator lost mid-run: how long until every source has a status.
    with swarm(base) as running:
        running.wait_until_ready()
        world = running.world
        pairs = len(evaluate_pairs(world.hood, policy))
        running.coordinator.discover(policy)
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
            shape=world.home_hood,
            namespace="swarm",
            context=running.context,
            key=running.key,
        )
        running.host.add(running.coordinator)
        began = time.monotonic()
        again = running.discover(policy, timeout=1800)
        lines.append(
            f"| coordinator lost mid-run | {until:.2f} | - | - | - | - "
            f"| {running.host.aborted} of {pairs} pairs ABORTED (status {ABORTED}) "
            f"{until:.2f} s after; a new coordinator's run {time.monotonic() - began:.1f} s: "
            f"{same(world, again, evaluate_pairs(world.hood, policy))} |"
        )
    return [*lines, ""]
