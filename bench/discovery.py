"""The whole-swarm computation made by the FLS nodes, next to the core engine.

The `discovery` section of BENCHMARKS.md (`python -m bench --sections discovery`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import RUN_LIMIT, SHAPE_SIZES, compute_all, swarm_cloud

#: The shapes whose Move Source also runs with --source-body (the engine's and the
#: swarm's body rule): every shape. Without it the swarm differs from the engine on
#: chess, palm, kangaroo, dragon, skateboard and the race car by 38, 27, 2, 98, 47 and
#: 10 statuses, and the engine's counts of pairs the body is in the way of were the same
#: on the five checked (all but the kangaroo; 2026-11-29). With the option the swarm
#: equalled the engine on chess and palm (the others not run yet).
SOURCE_BODY_SHAPES = tuple(SHAPE_SIZES)
SOURCE_BODY = "move-source --source-body"


def discovery_section(
    args: argparse.Namespace,
    sizes: dict[str, int] = SHAPE_SIZES,
    techniques: Sequence[str] = ("plain", "move-obstructing", "move-source"),
    domain: int = 92,
) -> list[str]:
    """The whole-swarm computation made by the FLS nodes, next to the core engine."""
    lines = [
        "## Distributed Swazure: `swazure spawn --compute-all`, beta 0.5, Shortest-Length",
        "",
        "One process holds every FLS node and the coordinator (two processes for the race",
        "car; config/swarm.yaml, the default parameters). Wall is the whole command:",
        "bring-up, the computation, the engine's run for comparison, writing summary.json and",
        "pairs.csv, and tearing the nodes down. Messages and bytes are every message the",
        "protocol publishes (docs/protocol.md; the world node's WorldState not counted), as",
        "serialized. Engine: `evaluate` (+ `run_technique`) in the same process, same work;",
        '"x engine" is (discovery s + moves s) / engine s.',
        'Move Source probes up to T = 10 steps. "Moves s" is the heuristic\'s part: planning,',
        "batches of moves (two world revisions each), path walks. A run still going after",
        f"{RUN_LIMIT['plain'] / 60:.0f} min (plain) or {RUN_LIMIT['move-obstructing'] / 60:.0f} "
        "min (a heuristic) is stopped; its row says how far it got.",
        "",
        "| shape | technique | processes | bring-up s | discovery s | rounds | moves s "
        "| batches | messages | MB | wall s | engine s | x engine | identical | peak MB |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
        "| ---: | --- | ---: |",
    ]
    for name, flss in sizes.items():
        processes = 2 if flss > 2000 else 1
        plain_failed = ""
        body = [SOURCE_BODY] if name in SOURCE_BODY_SHAPES and "move-source" in techniques else []
        for technique in [*techniques, *body]:
            if plain_failed:
                # A heuristic starts from the whole-swarm plain run.
                blank = " |" * 11
                lines.append(
                    f"| {name} | {technique} | {processes} | not run: it starts from the plain "
                    f"run, {plain_failed} |{blank}"
                )
                continue
            named, *options = technique.split()
            with tempfile.TemporaryDirectory() as out:
                row = compute_all(
                    swarm_cloud(name), named, domain, Path(out), processes,
                    RUN_LIMIT[named], *options,
                )  # fmt: skip
            print(f"compute-all {name} {technique}: {row}", flush=True)
            if "failed" in row:
                plain_failed = str(row["failed"]) if technique == "plain" else ""
                blank = " |" * 11
                lines.append(f"| {name} | {technique} | {processes} | {row['failed']} |{blank}")
                continue
            lines.append(discovery_row(name, technique, processes, row))
    lines += [
        "",
        "Move Source made by the swarm differs from the engine where the source, at its probe",
        "point, blocks the helper's view of the target: the helper cannot measure that hop, the",
        "walk fails and the pair keeps its plain result. The spec's Move Source (section 8), and",
        "so the engine, does not check this (docs/protocol.md); the comparison counts those",
        "pairs. With `--source-body` the engine and the swarm check it, and the swarm's Move",
        "Source is the engine's.",
        "",
        "Targets (issue 16): plain discovery, chess under 10 s, dragon under 60 s, race car",
        "under 10 minutes; Move Obstructing by the swarm, chess under 60 s, dragon under 5",
        "minutes, race car under 15 minutes; Move Source T=10 on every shape; identical to",
        "the engine but for the documented walk failures.",
        "",
    ]
    return lines


def discovery_row(name: str, technique: str, processes: int, row: dict[str, Any]) -> str:
    """One --compute-all run's row: its phases, traffic and time beside the engine's."""
    moving = f"{row['moving']:.1f}" if technique != "plain" else "-"
    if row.get("timeouts"):
        # Each wait that ended at its deadline cost round_timeout seconds.
        moving += f" ({row['timeouts']} timed out)"
    batches = f"{row['batches']:,}" if technique != "plain" else "-"
    # The swarm's computation (discovery and moves) over the engine's for the same work.
    times_engine = (row["discovery"] + row["moving"]) / max(row["engine"], 1e-9)
    return (
        f"| {name} | {technique} | {processes} | {row['bring_up']:.1f} "
        f"| {row['discovery']:.1f} | {row['rounds']} | {moving} | {batches} "
        f"| {row['messages']:,} | {row['bytes'] / 1e6:,.0f} | {row['wall']:.1f} "
        f"| {row['engine']:.1f} | {times_engine:.1f} | {row['identical']} "
        f"| {row['peak']} |"
    )
