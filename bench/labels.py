"""Labels by the search's reach: what each FLS holds in one discovery, against the swarm's size.

The `labels` section of BENCHMARKS.md (`python -m bench --sections labels`).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from bench.common import REPO, SECTIONS_DIR
from swazure_ros.files.atomic import atomic_write


#: One in-memory discovery of the labels section.
class LabelRun(NamedTuple):
    cloud: str  # a built-in shape, or ``pendant-grid:SIDE`` (pendant_grid)
    scale: float | None = None
    radius: float | None = None  # cm, instead of beta


#: The built-in torus spread out three times (FLSs 3 x the paper's spacing apart, so
#: that a display is several sensor reaches across) from 1,000 to 8,000 FLSs, and at the
#: paper's density, where every search reaches every FLS; then the pendant grid from 449
#: to 7,129 FLSs, whose every pair is out of sweet reach (pendant_grid).
LABEL_RUNS: tuple[LabelRun, ...] = (
    LabelRun("torus:1000", 3.0),
    LabelRun("torus:2000", 3.0),
    LabelRun("torus:4000", 3.0),
    LabelRun("torus:8000", 3.0),
    LabelRun("torus:2000"),
    LabelRun("pendant-grid:20", 1.0, 0.5),
    LabelRun("pendant-grid:40", 1.0, 0.5),
    LabelRun("pendant-grid:80", 1.0, 0.5),
)

#: The longest one run may take, s.
LABEL_LIMIT = 1800

#: The pendant grid's spacing and the pendants' height, cm (FLS radius 0.5 cm, the
#: published sensor: sweet from 6 to 8 cm of tracking distance).
GRID_SPACING, PENDANT_HEIGHT = 7.0, 6.0


def pendant_grid(side: int, path: Path) -> Path:
    """Write the pendant grid of ``side`` x ``side`` FLSs to ``path`` (.xyz, cm); return it.

    A flat square grid 7 cm apart, each FLS sweet to its four neighbours
    (6 cm of tracking distance at radius 0.5 cm), and 6 cm above every third
    FLS of every third row a pendant FLS: blind to the FLS below it
    (5 cm), decaying to every other (8.2 cm or more). A pendant has no sweet
    hop at all, so neither its search nor the search of the FLS below it finds
    the other in the sweet phases: without a bound, that FLS's search labels
    the whole grid, and every FLS holds a label of every such source.
    """
    spaced = np.arange(side) * GRID_SPACING
    x, y = np.meshgrid(spaced, spaced, indexing="ij")
    grid = np.column_stack([x.ravel(), y.ravel(), np.zeros(side * side)])
    row, column = np.divmod(np.arange(side * side), side)
    below = grid[(row % 3 == 1) & (column % 3 == 1)]
    points = np.vstack([grid, below + np.array([0.0, 0.0, PENDANT_HEIGHT])])
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda out: np.savetxt(out, points, fmt="%.3f"))
    return path


def labels_section(
    args: argparse.Namespace,
    runs: Sequence[LabelRun] = LABEL_RUNS,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """Labels by the search's reach: what each FLS holds in one in-memory discovery."""
    records = [label_record(run, args.beta, records_dir) for run in runs]
    labels_figure(records, figures / "labels-reach.png")
    return labels_lines(records)


def label_record(run: LabelRun, beta: float, records_dir: Path = SECTIONS_DIR) -> dict[str, Any]:
    """One bench.measure_labels run: its record, or why it stopped."""
    shape, scale = run.cloud, run.scale
    name = f"labels-{shape.replace(':', '')}-{scale or 1}"
    out = records_dir / f"{name}.json"
    print(f"bench: labels, {shape} at scale {scale or 1}", flush=True)
    cloud = shape
    if shape.startswith("pendant-grid:"):
        cloud = str(pendant_grid(int(shape.split(":")[1]), records_dir / f"{name}.xyz"))
    command = [sys.executable, "-m", "bench.measure_labels", "--cloud", cloud,
               "--beta", str(beta), "--out", str(out)]  # fmt: skip
    if scale is not None:
        command += ["--scale", str(scale)]
    if run.radius is not None:
        command += ["--radius", str(run.radius)]
    try:
        done = subprocess.run(command, timeout=LABEL_LIMIT, capture_output=True, text=True)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or [""])[-1]
            raise OSError(f"exit {done.returncode}: {last}")
        return {**json.loads(out.read_text()), "cloud": shape}
    except (subprocess.TimeoutExpired, OSError, ValueError) as err:
        return {"cloud": shape, "scale": scale, "stopped": str(err)[:160]}


def labels_lines(records: list[dict[str, Any]]) -> list[str]:
    """The labels section's table."""
    lines = [
        "## Labels by the search's reach: what each FLS holds in one discovery",
        "",
        "`bench/measure_labels.py`: one in-memory discovery (`protocol.loops.discover`,",
        "every FLS a source, beta 0.5, Shortest-Length, the FLSs stepped together as in a",
        "packed process) beside the engine's pairs, compared pair for pair. An FLS keeps a",
        "label only for a source whose search reached it (`protocol/discovery/labels.py`),",
        "and a phase's first pass relays labels as far as eight sweet hops: a search cut",
        "short goes on in the next pass, twice as far, unless its source or its target is",
        'shown out of reach (docs/protocol.md, "Passes"). Labels per FLS: the most held',
        "at once, over the FLSs, and the fullest row. Scale 3: FLSs three times the paper's",
        "spacing apart, so that the torus is several sensor reaches across. The pendant",
        "grid (`bench/labels.py`, radius 0.5 cm): a flat grid of FLSs 7 cm apart and, 6 cm",
        "above every ninth, a pendant FLS with no sweet hop; each pair is out of sweet reach,",
        "and without a bound each search of the sweet phases labels the whole grid.",
        "Peak MB: the whole process (world, engine and discovery). Figure:",
        "docs/figures/labels-reach.png.",
        "",
        "| shape | scale | FLSs | discovery s | engine s | rounds | CPU ms per FLS-round "
        "| labels per FLS, mean at once | labels in the fullest row | of the FLSs, % "
        "| peak MB | identical |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for record in records:
        scale = record.get("scale") or 1
        if "stopped" in record:
            lines.append(f"| {record['cloud']} | {scale} | stopped: {record['stopped']} "
                         "|  |  |  |  |  |  |  |  |  |")  # fmt: skip
            continue
        flss = record["flss"]
        lines.append(
            f"| {record['cloud']} | {scale:g} | {flss:,} | {record['discovery_s']:.1f} "
            f"| {record['engine_s']:.2f} | {record['rounds']} "
            f"| {1e3 * record['cpu_s'] / flss / max(record['rounds'], 1):.3f} "
            f"| {record['labels_at_once'] / flss:,.0f} | {record['labels_most_in_a_row']:,} "
            f"| {100 * record['labels_most_in_a_row'] / flss:.0f} | {record['peak_mb']:,.0f} "
            f"| {'yes' if record['identical'] else 'NO'} |"
        )
    return lines


def labels_figure(records: list[dict[str, Any]], path: Path) -> None:
    """Labels in the fullest row and discovery time against the swarm's size, per shape."""
    from matplotlib.figure import Figure

    done = [r for r in records if "stopped" not in r]
    torus = [r for r in done if r["cloud"].startswith("torus") and r.get("scale") == 3.0]
    grid = [r for r in done if r["cloud"].startswith("pendant-grid")]
    series = {"torus, 3 x the paper's spacing": torus, "pendant grid": grid}
    figure = Figure(figsize=(9.6, 4.0), layout="constrained")
    labels_axes, time_axes = figure.subplots(1, 2)
    for colour, (name, runs) in zip(("C0", "C1"), series.items(), strict=True):
        runs = sorted(runs, key=lambda r: r["flss"])
        flss = [r["flss"] for r in runs]
        labels_axes.plot(flss, [r["labels_most_in_a_row"] for r in runs], marker="s",
                         color=colour, label=f"{name}: the fullest row")  # fmt: skip
        labels_axes.plot(flss, [r["labels_at_once"] / r["flss"] for r in runs], marker="o",
                         color=colour, linestyle=":", label=f"{name}: mean")  # fmt: skip
        time_axes.plot(flss, [1e3 * r["cpu_s"] / r["flss"] for r in runs], marker="o",
                       color=colour, label=name)  # fmt: skip
    labels_axes.set_ylabel("labels an FLS holds in a phase")
    labels_axes.set_yscale("log")  # the torus's thousands beside the grid's tens
    time_axes.set_ylabel("discovery CPU ms per FLS")
    time_axes.set_ylim(bottom=0)
    for axes in (labels_axes, time_axes):
        axes.set_xlabel("FLSs")
        axes.grid(alpha=0.3)
        axes.legend(fontsize=8)
    figure.suptitle("Labels by the search's reach: one in-memory discovery, every FLS a source")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda out: figure.savefig(out, dpi=110, format="png"))
