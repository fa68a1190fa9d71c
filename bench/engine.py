"""Core engine and heuristics on the six shapes.

The `engine` section of BENCHMARKS.md (`python -m bench --sections engine`).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from bench.common import DATASETS, HEURISTICS, POLICIES, SHAPES, SWAZURE, run


def engine_section(args: argparse.Namespace) -> list[str]:
    """Core engine and heuristics on the six shapes."""
    swazure = SWAZURE
    rows = []
    heuristic_rows = []
    with tempfile.TemporaryDirectory() as scratch:

        def evaluate(shape: str, *options: str) -> tuple[dict, float, float]:
            out = Path(scratch) / "-".join([shape, *options]).replace("--", "")
            seconds, memory, code = run(
                [
                    *swazure,
                    "evaluate",
                    "--cloud",
                    str(DATASETS / f"{shape}.xyz"),
                    "--beta",
                    str(args.beta),
                    "--quiet",
                    "--out",
                    str(out),
                    *options,
                ]
            )
            if code != 0:
                raise SystemExit(f"bench: {shape} {options} failed with exit code {code}")
            summary = json.loads((out / "summary.json").read_text())
            print(
                f"{shape:16} {' '.join(options):45} {seconds:7.2f} s {memory:7.0f} MB", flush=True
            )
            return summary, seconds, memory

        for shape in SHAPES:
            for policy in POLICIES:
                summary, seconds, memory = evaluate(shape, "--policy", policy)
                rows.append((shape, policy, summary, seconds, memory))
        for shape in SHAPES:
            for technique, threshold in HEURISTICS:
                options = ["--policy", "shortest-length", "--technique", technique]
                if threshold is not None:
                    options += ["--threshold", str(threshold)]
                summary, seconds, memory = evaluate(shape, *options)
                heuristic_rows.append((shape, technique, threshold, summary, seconds, memory))
    lines = [
        f"## Core engine: `swazure evaluate`, every ordered blind pair, beta {args.beta}",
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
        f"## Heuristics: Move Obstructing and Move Source, Shortest-Length, beta {args.beta}",
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
