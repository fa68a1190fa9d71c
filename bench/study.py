"""The full default study, cold and with nothing changed.

The `study` section of BENCHMARKS.md (`python -m bench --sections study`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path

from bench.common import SWAZURE, du_mb, run
from swazure_ros.files.results import SUMMARY_FILE
from swazure_ros.files.runs import read_summary


def study_section(
    args: argparse.Namespace,
    options: Sequence[str] = (),
    shape: str = "chess_408",
    runs: int = 162,
) -> list[str]:
    """The full default study, cold and with nothing changed.

    ``options`` narrow the study (a smoke test's); ``shape`` is one of its shapes and
    ``runs`` how many runs it computes cold.
    """
    lines = [
        "## The published study: `swazure study --jobs 2`",
        "",
        "6 shapes x 6 betas x 3 policies of plain Swazure, plus Move Obstructing and Move",
        "Source (T = 2, T = 10) at beta 0.3, 0.4, 0.5 with Shortest-Length: 162 runs,",
        "per-pair output compact, kept for the runs the figures read (the default; every",
        "run's, with `--keep-pairs`, came to 4.49 GB on 2026-11-29).",
        "Cold: an empty output folder; cached: the same command again. Peak memory is the",
        "largest single process (a race car run in a worker).",
        "",
        "| case | runs computed | wall s | peak MB | output MB |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "study"
        for case in ("cold", "cached"):
            command = [*SWAZURE, "study", "--out", str(out), "--jobs", "2", "--quiet", *options]
            seconds, memory, code = run(command)
            if code != 0:
                raise SystemExit(f"bench: study ({case}) failed with exit code {code}")
            plain = out / "runs" / shape / "beta-0.5" / "shortest-length" / "plain"
            # The study wrote the shape's run under its cache key.
            if read_summary(plain / SUMMARY_FILE).study is None:
                raise SystemExit(f"bench: study ({case}): {plain} has no cache key")
            computed = runs if case == "cold" else 0
            print(f"study {case}: {seconds:.1f} s, {memory:.0f} MB", flush=True)
            lines.append(
                f"| {case} | {computed} | {seconds:.1f} | {memory:.0f} | {du_mb(out):,.0f} |"
            )
    lines += ["", "Targets (issue 5): under 15 minutes cold, under 10 s with nothing changed.", ""]
    return lines
