"""Core engine and heuristics on the six shapes.

The `engine` section of BENCHMARKS.md (`python -m bench --sections engine`).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import HEURISTICS, POLICIES, SHAPES, SWAZURE, run, swarm_cloud


def engine_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = SHAPES,
    policies: Sequence[str] = POLICIES,
    heuristics: Sequence[tuple[str, int | None]] = HEURISTICS,
) -> list[str]:
    """Core engine and heuristics on the six shapes."""
    rows = []
    heuristic_rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for shape in shapes:
            for policy in policies:
                summary, seconds, memory = timed_evaluate(
                    Path(scratch), shape, args.beta, "--policy", policy
                )
                rows.append((shape, policy, summary, seconds, memory))
        for shape in shapes:
            for technique, threshold in heuristics:
                options = ["--policy", "shortest-length", "--technique", technique]
                if threshold is not None:
                    options += ["--threshold", str(threshold)]
                summary, seconds, memory = timed_evaluate(
                    Path(scratch), shape, args.beta, *options
                )
                heuristic_rows.append((shape, technique, threshold, summary, seconds, memory))
    return engine_lines(args.beta, rows, heuristic_rows)


def timed_evaluate(
    scratch: Path, shape: str, beta: float, *options: str
) -> tuple[dict[str, Any], float, float]:
    """One `swazure evaluate` of ``shape``: its summary.json, wall s and peak MB."""
    out = scratch / "-".join([shape, *options]).replace("--", "").replace(":", "")
    seconds, memory, code = run(
        [*SWAZURE, "evaluate", "--cloud", swarm_cloud(shape), "--beta", str(beta), "--quiet",
         "--out", str(out), *options]
    )  # fmt: skip
    if code != 0:
        raise SystemExit(f"bench: {shape} {options} failed with exit code {code}")
    summary = json.loads((out / "summary.json").read_text())
    print(f"{shape:16} {' '.join(options):45} {seconds:7.2f} s {memory:7.0f} MB", flush=True)
    return summary, seconds, memory


def engine_lines(
    beta: float, rows: list[tuple[Any, ...]], heuristic_rows: list[tuple[Any, ...]]
) -> list[str]:
    """The engine's and the heuristics' tables from their runs."""
    lines = [
        f"## Core engine: `swazure evaluate`, every ordered blind pair, beta {beta}",
        "",
        "Wall time of the whole process (start-up, reading, evaluating, writing summary.json",
        "and pairs.csv), its peak resident memory, and the engine's own time (summary.json",
        "`seconds`: neighbours, line of sight, paths, estimates, metrics).",
        "",
        "| shape | policy | FLSs | ordered blind pairs | sweet % | decaying % | no path % "
        "| wall s | engine s | peak MB |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for shape, policy, summary, seconds, memory in rows:
        lines.append(
            f"| {shape} | {policy} | {summary['flss']} | {summary['blind_pairs']:,} "
            f"| {summary['sweet_pct']:.3f} | {summary['decaying_pct']:.3f} "
            f"| {summary['no_path_pct']:.3f} | {seconds:.1f} | {summary['seconds']:.1f} "
            f"| {memory:.0f} |"
        )
    lines += [
        "",
        f"## Heuristics: Move Obstructing and Move Source, Shortest-Length, beta {beta}",
        "",
        "Wall time includes the plain evaluation the heuristic starts from. Tried pairs are",
        "the BLOCKED pairs without a sweet path; % of all ordered blind pairs after the",
        "heuristic (plain Swazure in the table above). Moves in cm: for Move Obstructing every",
        "individual FLS move, for Move Source the net displacement of the source.",
        "",
        "| shape | technique | T | tried | resolved | no path % | decaying % | moves "
        "| mean move | max move | mean flown | wall s | peak MB |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: "
        "| ---: |",
    ]
    for shape, technique, threshold, summary, seconds, memory in heuristic_rows:
        moved = summary["moved_distance"]
        flown = summary.get("flown_distance", {}).get("mean")
        lines.append(
            f"| {shape} | {technique} | {threshold or '-'} | {summary['tried_pairs']:,} "
            f"| {summary['resolved_pairs']:,} | {summary['no_path_pct']:.3f} "
            f"| {summary['decaying_pct']:.3f} | {moved['count']:,} "
            f"| {moved['mean'] or 0:.3f} | {moved['max'] or 0:.3f} "
            f"| {'-' if flown is None else f'{flown:.2f}'} | {seconds:.1f} | {memory:.0f} |"
        )
    lines += [
        "",
        "Targets (issue 4): the race car under 2 minutes for each heuristic.",
        "Targets (issue 3): race car under 60 s and 4 GB for either policy; chess piece",
        "under 2 s. The published reference implementation took 64 s (chess), 549 s (palm)",
        "and 886 s (kangaroo) on this machine.",
        "",
    ]
    return lines
