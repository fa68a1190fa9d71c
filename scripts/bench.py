"""Benchmarks of the core engine; writes BENCHMARKS.md (run by `make bench`).

Each run is a separate `swazure evaluate` process, timed from outside (wall
time, process start included) with its peak resident memory from wait4.
Needs the published point clouds in ../shared/datasets/swazure-paper/.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATASETS = REPO.parent / "shared" / "datasets" / "swazure-paper"
SHAPES = ["chess_408", "palm_725", "kangaroo_972", "dragon_1147", "skateboard_1372",
          "racecar_3720"]  # fmt: skip
POLICIES = ["fewest-hops", "shortest-length"]


def machine() -> str:
    model = "unknown CPU"
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            model = line.split(":", 1)[1].strip()
            break
    memory_kb = int(Path("/proc/meminfo").read_text().split()[1])
    return (
        f"{model}, {os.cpu_count()} cores, {memory_kb / 2**20:.0f} GiB, "
        f"{platform.system()} {platform.release()}, Python {platform.python_version()}"
    )


def run(arguments: list[str]) -> tuple[float, float, int]:
    """Run a command; return wall seconds, peak RSS in MB, exit code."""
    began = time.perf_counter()
    process = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    seconds = time.perf_counter() - began
    return seconds, usage.ru_maxrss / 1024, os.waitstatus_to_exitcode(status)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--beta", type=float, default=0.5)
    parser.add_argument("--output", type=Path, default=REPO / "BENCHMARKS.md")
    args = parser.parse_args()
    if not DATASETS.is_dir():
        print(f"bench: {DATASETS} is absent; the benchmarks need the published clouds",
              file=sys.stderr)  # fmt: skip
        return 2
    swazure = [sys.executable, "-m", "swazure_ros.cli.main"]
    # Warm numba's compilation cache so that no run pays for compiling.
    run([*swazure, "evaluate", "--cloud", "sphere:200", "--beta", "0.5", "--quiet"])
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for shape in SHAPES:
            for policy in POLICIES:
                out = Path(scratch) / f"{shape}-{policy}"
                seconds, memory, code = run([
                    *swazure, "evaluate", "--cloud", str(DATASETS / f"{shape}.xyz"),
                    "--beta", str(args.beta), "--policy", policy, "--quiet", "--out", str(out),
                ])  # fmt: skip
                if code != 0:
                    print(f"bench: {shape} {policy} failed with exit code {code}",
                          file=sys.stderr)  # fmt: skip
                    return 1
                summary = json.loads((out / "summary.json").read_text())
                rows.append((shape, policy, summary, seconds, memory))
                print(f"{shape:16} {policy:16} {seconds:7.2f} s {memory:7.0f} MB "
                      f"engine {summary['seconds']:6.2f} s", flush=True)  # fmt: skip
    lines = [
        "# Benchmarks",
        "",
        f"Measured {datetime.date.today().isoformat()} on {machine()}.",
        "Regenerate with `make bench` (writes this file).",
        "",
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
        "Targets (issue 3): race car under 60 s and 4 GB for either policy; chess piece",
        "under 2 s. The published reference implementation took 64 s (chess), 549 s (palm)",
        "and 886 s (kangaroo) on this machine.",
        "",
    ]
    args.output.write_text("\n".join(lines))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
