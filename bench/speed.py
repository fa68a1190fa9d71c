"""Issues 34 and 68's command-line targets: the engine's wall on two shapes with its
outputs, where that wall goes, and start-up.

The `speed` section of BENCHMARKS.md (`python -m bench --sections speed`).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from bench.common import run, run_output, swarm_cloud


def median_wall(arguments: list[str], times: int) -> tuple[float, float, float]:
    """Median, lowest and highest wall seconds of ``times`` runs of a command that must pass."""
    walls = []
    for _ in range(times):
        seconds, _, code = run(arguments)
        if code != 0:
            raise SystemExit(f"bench: {' '.join(arguments)} failed with exit code {code}")
        walls.append(seconds)
    walls.sort()
    return walls[len(walls) // 2], walls[0], walls[-1]


#: The engine's wall on two shapes: (shape, runs, target).
SPEED_SHAPES = (("racecar_3720", 3, "10 s"), ("chess_408", 5, "1.0 s"))
#: The verbs whose --help the section times.
HELP_VERBS = ("evaluate", "study", "spawn", "echo", "query", "replay", "track", "camera", "key")


def speed_section(
    args: argparse.Namespace,
    shapes: Sequence[tuple[str, int, str]] = SPEED_SHAPES,
    verbs: Sequence[str] = HELP_VERBS,
    times: int | None = None,
) -> list[str]:
    """Issue 34's command-line targets: the engine's wall on two shapes, and start-up.

    ``times`` runs of each command when given, else each command's own count.
    """
    swazure = [str(Path(sys.executable).parent / "swazure")]
    rows, phases = [], []
    with tempfile.TemporaryDirectory(prefix="bench-speed-") as out:
        for shape, runs, target in shapes:
            arguments = ["evaluate", "--cloud", swarm_cloud(shape), "--beta", str(args.beta),
                         "--quiet", "--out", out]  # fmt: skip
            rows.append(
                speed_row(
                    f"`swazure evaluate --out` {shape}, beta {args.beta}, shortest-length",
                    target,
                    [*swazure, *arguments],
                    times or runs,
                )
            )
            phases.append(phase_row(shape, arguments))
    rows.append(speed_row("`swazure --version`", "0.3 s", [*swazure, "--version"], times or 5))
    for verb in verbs:
        target = "0.5 s" if verb == "evaluate" else "0.5 s (evaluate's target)"
        rows.append(
            speed_row(f"`swazure {verb} --help`", target, [*swazure, verb, "--help"], times or 3)
        )
    return [
        "## Speed targets (issues 34, 68): the engine's wall and the command line's start-up",
        "",
        "Wall time of the whole installed `swazure` command, timed from outside, process",
        "start included; the median of several runs (range beside it). `evaluate` writes",
        "its outputs (`--out`: pairs.csv, summary.json, record.json; the race car's",
        "pairs.csv is 2.07 M rows, 581 MB). The packed swarm's bring-up is in the",
        "`swazure spawn` section, and the distributed runs beside the engine in the",
        "`--compute-all` section.",
        "",
        "| command | runs | median s | range s | target | met |",
        "| --- | ---: | ---: | --- | --- | --- |",
        *rows,
        "",
        "Where one run's wall goes (`python -m bench.phases`, one run each, seconds to the",
        "millisecond: a small shape's pairs.csv takes a few):",
        "start-up is the interpreter's own start and exit (the wall from outside less the",
        "rest); imports, the command line's and the verb's; kernels, numba's import and",
        "each kernel's first dispatch from its cache on disk; tables, the pairs' pyarrow",
        "tables; pairs.csv, its text formatted and written on the writer thread, partly",
        "beside the engine, whose figure is the rest of the run less it (a lower bound).",
        "",
        "| shape | wall s | start-up | imports | kernels | engine | tables | pairs.csv |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
        *phases,
        "",
    ]


def phase_row(shape: str, arguments: list[str]) -> str:
    """One run of ``swazure`` with ``arguments`` in ``bench.phases``: its wall per phase."""
    seconds, _, code, output = run_output([sys.executable, "-m", "bench.phases", *arguments])
    if code != 0:
        raise SystemExit(f"bench: bench.phases {' '.join(arguments)} failed with exit code {code}")
    phase = json.loads(output.strip().splitlines()[-1])
    start = seconds - phase["imports"] - phase["run"]
    print(f"phases {shape}: {seconds:.2f} s {phase}", flush=True)
    cells = [phase[name] for name in ("imports", "kernels", "engine", "tables", "csv")]
    return (
        f"| {shape} | {seconds:.3f} | {start:.3f} | "
        + " | ".join(f"{c:.3f}" for c in cells)
        + " |"
    )


def speed_row(what: str, target: str, arguments: list[str], times: int) -> str:
    """One command's row: the median wall of ``times`` runs against its target."""
    middle, low, high = median_wall(arguments, times)
    met = "yes" if middle < float(target.split()[0]) else "no"
    print(f"speed {what}: {middle:.2f} s ({low:.2f}-{high:.2f})", flush=True)
    return f"| {what} | {times} | {middle:.2f} | {low:.2f}-{high:.2f} | < {target} | {met} |"
