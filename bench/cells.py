"""Radio cells: per packed process and FLS, what one discovery run hears and spends.

The `cells` section of BENCHMARKS.md (`python -m bench --sections cells`). Runs measured
one by one (``python -m bench.measure_cells``, hours each at display size) are put
together with ``python -m bench.cells --figure PNG RECORD.json ...``: the section's table
and figure of those records.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import REPO, SECTIONS_DIR, swarm_cloud, table_cell

#: (shape, processes) of the cells section: the built-in torus at the paper's density and
#: the race car, packed over 1, 2 and 4 processes; the other published shapes in one process
#: (discovery against the engine on every published shape); then issue 67's display sizes:
#: torus:10000 over one and two, torus:30000 and torus:65536 over four (each process holds
#: its own FLSs' observations and pairs, the launcher's comparison goes block by block).
CELL_RUNS = (
    [(shape, 1) for shape in ("chess_408", "palm_725", "kangaroo_972", "dragon_1147")]
    + [("skateboard_1372", 1)]
    + [
        (shape, processes)
        for shape in ("torus:400", "torus:1000", "torus:3720", "racecar_3720")
        for processes in (1, 2, 4)
    ]
    + [("torus:10000", 1), ("torus:10000", 2), ("torus:30000", 4), ("torus:65536", 4)]
)


#: The longest a cells run may take, s: its row then says it was stopped; a display-size
#: swarm's (30,000 FLSs and more) may take longer.
CELL_LIMIT = 1800
DISPLAY_LIMIT = 4 * 3600
#: FLSs from which a swarm is of display size.
DISPLAY_FLSS = 30_000


def cells_section(
    args: argparse.Namespace,
    runs: Sequence[tuple[str, int]] = CELL_RUNS,
    domain: int = 93,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """Radio cells: per packed process and FLS, what one discovery run hears and spends."""
    records = [
        cell_record(shape, processes, args.beta, domain, records_dir) for shape, processes in runs
    ]
    cells_figure(records, figures / "cells-per-fls.png")
    return cells_lines(records)


def cell_record(
    shape: str, processes: int, beta: float, domain: int = 93, records_dir: Path = SECTIONS_DIR
) -> dict[str, Any]:
    """One measure_cells run of ``shape`` over ``processes``: its record, or why it stopped."""
    cloud = swarm_cloud(shape)
    out = records_dir / f"cells-{shape.replace(':', '')}-{processes}.json"
    print(f"bench: cells, {shape} over {processes} process(es)", flush=True)
    command = [sys.executable, "-m", "bench.measure_cells", "--cloud", cloud,
               "--processes", str(processes), "--beta", str(beta),
               "--domain-id", str(domain), "--out", str(out)]  # fmt: skip
    try:
        size = int(shape.split(":")[1]) if shape.startswith("torus:") else 0
        limit = DISPLAY_LIMIT if size >= DISPLAY_FLSS else CELL_LIMIT
        done = subprocess.run(command, timeout=limit, capture_output=True, text=True)
        if done.returncode != 0:
            said = [line for line in done.stderr.splitlines() if "bench_cells:" in line]
            where = said[-1].split("bench_cells: ", 1)[-1] if said else "before bring-up"
            killed = done.returncode == -signal.SIGKILL or "code -9" in done.stderr
            last = (done.stderr.strip().splitlines() or [""])[-1]
            why = f"{oom_kill()} during: {where}" if killed else f"exit {done.returncode}: {last}"
            raise OSError(why)
        return {"shape": shape, **json.loads(out.read_text())}
    except (subprocess.TimeoutExpired, OSError, ValueError) as err:
        return {"shape": shape, "processes": processes, "stopped": str(err)[:160]}


def oom_kill() -> str:
    """What the kernel's log says of the last process it killed for memory, in a few words."""
    try:
        log = subprocess.run(["dmesg"], capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.TimeoutExpired):
        log = ""
    kills = re.findall(r"Out of memory: Killed process \d+ .*?anon-rss:(\d+)kB", log)
    if not kills:
        return "killed (SIGKILL: out of memory?)"
    return f"a process killed by the kernel at {int(kills[-1]) / 1024**2:.1f} GB (out of memory)"


def cells_lines(records: list[dict[str, Any]]) -> list[str]:
    """The cells section's table from the bench.measure_cells records."""
    lines = [
        "## Radio cells: what each packed process hears and spends in one discovery",
        "",
        "`bench/measure_cells.py`: one `spawn --compute-all`-like run (beta 0.5,",
        "Shortest-Length) of every published shape in one process, and of the built-in",
        "torus at the paper's density and the race car packed over 1, 2 and 4 processes",
        "(k-d regions). Per process: the FLSs it",
        "hosts, the radio cells it subscribes to (ROS graph), the offers it heard over DDS",
        "(its /diagnostics counts; offers between its own FLSs never cross DDS), the bytes",
        "of the offers it heard, and its CPU during discovery (/proc). Per FLS and round:",
        "those offers, bytes and CPU over the process's FLSs and the run's rounds (the",
        "busiest process; bytes counted from e15b506 on, '-' before). The coordinator",
        "hears no offer. Peak MB: at bring-up (all processes); per process, the peak",
        "of the whole run (VmHWM; process 0's includes the engine's comparison).",
        "Source runs: the blocks of sources searched one run after the other, so that the",
        'labels fit (docs/protocol.md, "Two ways in"); rounds are all runs\' together.',
        "Figure: docs/figures/cells-per-fls.png.",
        "",
        "| shape | FLSs | processes | bring-up s | peak MB | discovery s | engine s | x engine "
        "| rounds | source runs | radio topics | cells heard per process "
        "| offers over DDS per process | share of the others' offers heard "
        "| DDS offers per FLS-round | DDS KB heard per FLS-round | CPU ms per FLS-round "
        "| radio MB | peak MB per process | identical |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- "
        "| --- | ---: | ---: | ---: | ---: | --- | --- |",
    ]
    for record in records:
        if "stopped" in record:
            lines.append(
                f"| {record['shape']} | - | {record['processes']} | stopped: "
                f"{record['stopped']} |  |  |  |  |  |  |  |  |  |  |  |  |  |  |  |  |"
            )
            continue
        per = record["per_process"]
        rounds = max(record["rounds"], 1)
        dds = max(one["offers_over_dds"] / max(one["flss"], 1) / rounds for one in per)
        spent = per_fls_round(record)
        cpu_ms, heard = spent["cpu_ms"], spent["heard_kb"]
        heard_kb = f"{heard:.2f}" if math.isfinite(heard) else "-"
        # Every live FLS sends an offer each round: what the others sent, heard.
        shares = [
            one["offers_over_dds"] / max((record["flss"] - one["flss"]) * rounds, 1) for one in per
        ]
        lines.append(
            f"| {record['shape']} | {record['flss']:,} | {record['processes']} "
            f"| {record['bring_up_s']:.1f} | {record['peak_mb']:.0f} "
            f"| {record['discovery_s']:.1f} | {record['engine_s']:.1f} "
            f"| {record['discovery_s'] / record['engine_s']:.1f} | {record['rounds']} "
            f"| {record.get('source_runs', 1)} "
            f"| {record['radio_topics']} | {' / '.join(str(one['cells']) for one in per)} "
            f"| {' / '.join(format(one['offers_over_dds'], ',') for one in per)} "
            f"| {' / '.join(f'{share:.0%}' for share in shares) if len(per) > 1 else '-'} "
            f"| {dds:.2f} | {heard_kb} | {cpu_ms:.2f} | {record['radio_bytes'] / 1e6:.0f} "
            f"| {' / '.join(table_cell(one, 'peak_mb', '.0f') for one in per)} "
            f"| {record['identical']} |"
        )
    lines += [
        "",
        "At the paper's density the sensor's reach (30.6 cm) spans most of these shapes,",
        "so a process still hears most of the other processes' offers; what each FLS",
        "costs per round grows with the swarm and with the processes sharing two cores.",
        "A process holds its own FLSs' observations and pairs (docs/swarm.md, \"A share of",
        'the world per process"); a run that stops says where in its row.',
    ]
    return lines


def per_fls_round(record: dict[str, Any]) -> dict[str, float]:
    """What the busiest process of a cells run spent per FLS it hosts: heard over DDS per
    round (KB; NaN in a record made before bytes were counted), CPU per round (ms), and
    its peak memory (KB)."""
    per = record["per_process"]
    rounds = max(int(record["rounds"]), 1)

    def busiest(field: str) -> float:
        return float(max(one.get(field, math.nan) / max(one["flss"], 1) for one in per))

    return {
        "heard_kb": busiest("bytes_over_dds") / rounds / 1e3,
        "cpu_ms": 1e3 * busiest("cpu_s") / rounds,
        "peak_kb": 1e3 * busiest("peak_mb"),
    }


def cells_figure(records: list[dict[str, Any]], path: Path) -> None:
    """Per FLS of the busiest process, against the FLSs in the swarm: bytes heard and CPU
    per round, and peak memory (issue 67: flat as the swarm grows)."""
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    panels = (
        ("heard_kb", "Offers heard over DDS", "KB per FLS and round"),
        ("cpu_ms", "CPU", "ms per FLS and round"),
        ("peak_kb", "Peak memory", "KB per FLS hosted"),
    )
    figure = Figure(figsize=(13.2, 4.2), layout="constrained")
    axes_of = dict(zip([name for name, *_ in panels], figure.subplots(1, 3), strict=True))
    for processes, marker, colour in ((1, "o", "C0"), (2, "s", "C1"), (4, "^", "C2")):
        done = [r for r in records if r.get("processes") == processes and "stopped" not in r]
        label = f"{processes} process{'es' if processes > 1 else ''}"
        for shapes, style in (("torus", "-"), ("racecar", "none")):
            mine = sorted(
                (r for r in done if r["shape"].startswith(shapes)), key=lambda r: r["flss"]
            )
            face = colour if shapes == "torus" else "none"
            name = label if shapes == "torus" else f"race car, {label}"
            for field, axes in axes_of.items():
                points = [(r["flss"], per_fls_round(r)[field]) for r in mine]
                points = [(x, y) for x, y in points if math.isfinite(y)]
                if field == "heard_kb" and processes == 1:
                    continue  # one process hears nothing over DDS
                if points:
                    axes.plot(*zip(*points, strict=True), marker=marker, color=colour,
                              linestyle=style, markerfacecolor=face, label=name)  # fmt: skip
    for field, title, unit in panels:
        axes = axes_of[field]
        axes.set_title(f"{title} (busiest process)", fontsize=10)
        axes.set_ylabel(unit)
        axes.set_ylim(bottom=0)
        axes.set_xscale("log")
        axes.set_xlabel("FLSs (torus at the paper's density; race car hollow)")
        axes.grid(True, alpha=0.3)
        if axes.get_legend_handles_labels()[0]:
            axes.legend(fontsize=8, loc="best")
        else:  # every run stopped, or none counted this (bytes: from e15b506 on)
            axes.text(0.5, 0.5, "not in these records", ha="center", transform=axes.transAxes)
    stopped = ", ".join(f"{r['shape']} stopped" for r in records if "stopped" in r)
    figure.suptitle("Packed discovery per FLS, 2 cores" + (f" ({stopped})" if stopped else ""))
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))


def main(argv: Sequence[str] | None = None) -> int:
    """The section's table (printed) and figure of bench.measure_cells records given by file."""
    parser = argparse.ArgumentParser(description=main.__doc__)
    parser.add_argument("records", nargs="+", type=Path, help="measure_cells records (JSON)")
    parser.add_argument("--figure", type=Path, required=True, help="the PNG to write")
    args = parser.parse_args(argv)
    try:
        records = [_named(json.loads(path.read_text())) for path in args.records]
    except (OSError, ValueError, KeyError) as err:
        parser.error(f"cannot read a record: {err}")
    cells_figure(records, args.figure)
    print("\n".join(cells_lines(records)))
    return 0


def _named(record: dict[str, Any]) -> dict[str, Any]:
    """A measure_cells record with the shape the section names it by (its cloud's)."""
    cloud = str(record["cloud"])
    return {"shape": cloud if ":" in cloud else Path(cloud).stem, **record}


if __name__ == "__main__":
    sys.exit(main())
