"""Core engine and heuristics on the six shapes.

The `engine` section of BENCHMARKS.md (`python -m bench --sections engine`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path

from bench.common import HEURISTICS, POLICIES, SHAPES, SWAZURE, run, swarm_cloud
from swazure_ros.core.summary import Summary
from swazure_ros.files.results import SUMMARY_FILE
from swazure_ros.files.runs import read_summary

#: A policy's run: shape, policy, its summary, wall s and peak MB.
PolicyRow = tuple[str, str, Summary, float, float]
#: A heuristic's run: shape, technique, threshold, its summary, wall s and peak MB.
HeuristicRow = tuple[str, str, int | None, Summary, float, float]


def engine_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = SHAPES,
    policies: Sequence[str] = POLICIES,
    heuristics: Sequence[tuple[str, int | None]] = HEURISTICS,
) -> list[str]:
    """Core engine and heuristics on the six shapes."""
    rows: list[PolicyRow] = []
    heuristic_rows: list[HeuristicRow] = []
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
) -> tuple[Summary, float, float]:
    """One `swazure evaluate` of ``shape``: its summary.json, wall s and peak MB."""
    out = scratch / "-".join([shape, *options]).replace("--", "").replace(":", "")
    seconds, memory, code = run(
        [*SWAZURE, "evaluate", "--cloud", swarm_cloud(shape), "--beta", str(beta), "--quiet",
         "--out", str(out), *options]
    )  # fmt: skip
    if code != 0:
        raise SystemExit(f"bench: {shape} {options} failed with exit code {code}")
    summary = read_summary(out / SUMMARY_FILE)
    print(f"{shape:16} {' '.join(options):45} {seconds:7.2f} s {memory:7.0f} MB", flush=True)
    return summary, seconds, memory


def engine_lines(
    beta: float, rows: list[PolicyRow], heuristic_rows: list[HeuristicRow]
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
        pairs = summary.pairs
        lines.append(
            f"| {shape} | {policy} | {summary.flss} | {pairs.blind_pairs:,} "
            f"| {pairs.sweet_pct:.3f} | {pairs.decaying_pct:.3f} "
            f"| {pairs.no_path_pct:.3f} | {seconds:.1f} | {summary.seconds or 0.0:.1f} "
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
        facts, pairs = summary.heuristic, summary.pairs
        if facts is None:
            raise SystemExit(f"bench: {shape} {technique}: its summary has no heuristic")
        moved = facts.moved_distance
        flown = None if facts.flown_distance is None else facts.flown_distance.mean
        lines.append(
            f"| {shape} | {technique} | {threshold or '-'} | {facts.tried_pairs:,} "
            f"| {facts.resolved_pairs:,} | {pairs.no_path_pct:.3f} "
            f"| {pairs.decaying_pct:.3f} | {moved.count:,} "
            f"| {moved.mean or 0:.3f} | {moved.max or 0:.3f} "
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
