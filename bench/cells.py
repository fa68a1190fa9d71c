"""Radio cells: per packed process and FLS, what one discovery run hears and spends.

The `cells` section of BENCHMARKS.md (`python -m bench --sections cells`).
"""

from __future__ import annotations

import argparse
import json
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
        "(its /diagnostics counts; offers between its own FLSs never cross DDS) and its",
        "CPU during discovery (/proc). Per FLS and round: those offers and that CPU over",
        "the process's FLSs and the run's rounds (the busiest process). The coordinator",
        "hears no offer. Peak MB: at bring-up (all processes); per process, the peak",
        "of the whole run (VmHWM; process 0's includes the engine's comparison).",
        "Source runs: the blocks of sources searched one run after the other, so that the",
        'labels fit (docs/protocol.md, "Two ways in"); rounds are all runs\' together.',
        "Figure: docs/figures/cells-per-fls.png.",
        "",
        "| shape | FLSs | processes | bring-up s | peak MB | discovery s | engine s | x engine "
        "| rounds | source runs | radio topics | cells heard per process "
        "| offers over DDS per process | share of the others' offers heard "
        "| DDS offers per FLS-round | CPU ms per FLS-round "
        "| radio MB | peak MB per process | identical |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | --- "
        "| --- | ---: | ---: | ---: | --- | --- |",
    ]
    for record in records:
        if "stopped" in record:
            lines.append(
                f"| {record['shape']} | - | {record['processes']} | stopped: "
                f"{record['stopped']} |  |  |  |  |  |  |  |  |  |  |  |  |  |  |  |"
            )
            continue
        per = record["per_process"]
        rounds = max(record["rounds"], 1)
        busiest = max(per, key=lambda one: one["cpu_s"])
        dds = max(one["offers_over_dds"] / max(one["flss"], 1) / rounds for one in per)
        cpu_ms = 1e3 * busiest["cpu_s"] / max(busiest["flss"], 1) / rounds
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
            f"| {dds:.2f} | {cpu_ms:.2f} | {record['radio_bytes'] / 1e6:.0f} "
            f"| {' / '.join(table_cell(one, 'peak_mb', '.0f') for one in per)} "
            f"| {record['identical']} |"
        )
    lines += [
        "",
        "At the paper's density the sensor's reach (30.6 cm) spans most of these shapes,",
        "so a process still hears most of the other processes' offers; what each FLS",
        "costs per round grows with the swarm and with the processes sharing two cores.",
        "Beyond them, memory is the wall: every process holds the whole world's",
        'observations, so a run\'s row says where it stopped (docs/swarm.md, "Locality").',
    ]
    return lines


def cells_figure(records: list[dict[str, Any]], path: Path) -> None:
    """Share of the other processes' offers heard, and CPU per FLS and round, against FLSs."""
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    def heard(record: dict[str, Any]) -> float:
        rounds = max(record["rounds"], 1)
        return 100 * float(
            max(
                one["offers_over_dds"] / max((record["flss"] - one["flss"]) * rounds, 1)
                for one in record["per_process"]
            )
        )

    def cpu(record: dict[str, Any]) -> float:
        per = record["per_process"]
        busiest = float(max(one["cpu_s"] / max(one["flss"], 1) for one in per))
        return 1e3 * busiest / int(record["rounds"])

    figure = Figure(figsize=(9.6, 4.0), layout="constrained")
    heard_axes, cpu_axes = figure.subplots(1, 2)
    for processes, marker, colour in ((1, "o", "C0"), (2, "s", "C1"), (4, "^", "C2")):
        done = [r for r in records if r.get("processes") == processes and "stopped" not in r]
        label = f"{processes} process{'es' if processes > 1 else ''}"
        for shapes, style in (("torus", "-"), ("racecar", "none")):
            mine = sorted(
                (r for r in done if r["shape"].startswith(shapes)), key=lambda r: r["flss"]
            )
            if not mine:
                continue
            flss = [r["flss"] for r in mine]
            face = colour if shapes == "torus" else "none"
            name = label if shapes == "torus" else f"race car, {label}"
            if processes > 1:
                heard_axes.plot(flss, [heard(r) for r in mine], marker=marker, color=colour,
                                linestyle=style, markerfacecolor=face, label=name)  # fmt: skip
            cpu_axes.plot(flss, [cpu(r) for r in mine], marker=marker, color=colour,
                          linestyle=style, markerfacecolor=face, label=name)  # fmt: skip
    heard_axes.set_ylabel("of the other processes' offers, % heard (busiest)")
    heard_axes.set_ylim(0, 105)
    cpu_axes.set_ylabel("CPU per FLS and round, ms (busiest process)")
    cpu_axes.set_ylim(bottom=0)
    for axes, corner in ((heard_axes, "lower left"), (cpu_axes, "upper left")):
        axes.set_xscale("log")
        axes.set_xlabel("FLSs in the swarm (torus at the paper's density; race car hollow)")
        axes.grid(True, alpha=0.3)
        if axes.get_legend_handles_labels()[0]:  # every run stopped: nothing to name
            axes.legend(fontsize=8, loc=corner)
    stopped = ", ".join(f"{r['shape']} stopped" for r in records if "stopped" in r)
    figure.suptitle(
        "Packed discovery with radio cells, 2 cores" + (f" ({stopped})" if stopped else "")
    )
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
