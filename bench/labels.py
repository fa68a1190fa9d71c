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
from typing import Any

from bench.common import REPO, SECTIONS_DIR

#: (shape, scale) of the labels section: the built-in torus spread out three times (FLSs
#: 3 x the paper's spacing apart, so that a display is several sensor reaches across)
#: from 1,000 to 8,000 FLSs, and at the paper's density, where every search reaches
#: every FLS.
LABEL_RUNS: tuple[tuple[str, float | None], ...] = (
    ("torus:1000", 3.0),
    ("torus:2000", 3.0),
    ("torus:4000", 3.0),
    ("torus:8000", 3.0),
    ("torus:2000", None),
)

#: The longest one run may take, s.
LABEL_LIMIT = 1800


def labels_section(
    args: argparse.Namespace,
    runs: Sequence[tuple[str, float | None]] = LABEL_RUNS,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """Labels by the search's reach: what each FLS holds in one in-memory discovery."""
    records = [label_record(shape, scale, args.beta, records_dir) for shape, scale in runs]
    labels_figure(records, figures / "labels-reach.png")
    return labels_lines(records)


def label_record(
    shape: str, scale: float | None, beta: float, records_dir: Path = SECTIONS_DIR
) -> dict[str, Any]:
    """One bench.measure_labels run: its record, or why it stopped."""
    name = f"labels-{shape.replace(':', '')}-{scale or 1}.json"
    out = records_dir / name
    print(f"bench: labels, {shape} at scale {scale or 1}", flush=True)
    command = [sys.executable, "-m", "bench.measure_labels", "--cloud", shape,
               "--beta", str(beta), "--out", str(out)]  # fmt: skip
    if scale is not None:
        command += ["--scale", str(scale)]
    try:
        done = subprocess.run(command, timeout=LABEL_LIMIT, capture_output=True, text=True)
        if done.returncode != 0:
            last = (done.stderr.strip().splitlines() or [""])[-1]
            raise OSError(f"exit {done.returncode}: {last}")
        return dict(json.loads(out.read_text()))
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
        "label only for a source whose search reached it (`protocol/discovery/labels.py`);",
        "one per source of the swarm before. Labels per FLS: the most held at once, over",
        "the FLSs, and the fullest row. Scale 3: FLSs three times the paper's spacing",
        "apart, so that the torus is several sensor reaches across. Peak MB: the whole",
        "process (world, engine and discovery). Figure: docs/figures/labels-reach.png.",
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
            f"| {record['cloud']} | {scale} | {flss:,} | {record['discovery_s']:.1f} "
            f"| {record['engine_s']:.2f} | {record['rounds']} "
            f"| {1e3 * record['cpu_s'] / flss / max(record['rounds'], 1):.3f} "
            f"| {record['labels_at_once'] / flss:,.0f} | {record['labels_most_in_a_row']:,} "
            f"| {100 * record['labels_most_in_a_row'] / flss:.0f} | {record['peak_mb']:,.0f} "
            f"| {'yes' if record['identical'] else 'NO'} |"
        )
    return lines


def labels_figure(records: list[dict[str, Any]], path: Path) -> None:
    """Labels per FLS and peak memory against the swarm's size, spread-out torus."""
    from matplotlib.figure import Figure

    from swazure_ros.files.atomic import atomic_write

    spread = sorted(
        (r for r in records if "stopped" not in r and r.get("scale")), key=lambda r: r["flss"]
    )
    figure = Figure(figsize=(9.6, 4.0), layout="constrained")
    labels_axes, memory_axes = figure.subplots(1, 2)
    flss = [r["flss"] for r in spread]
    labels_axes.plot(flss, flss, color="0.6", linestyle="--", label="one per source (before)")
    labels_axes.plot(flss, [r["labels_most_in_a_row"] for r in spread], marker="s",
                     color="C1", label="the fullest row")  # fmt: skip
    labels_axes.plot(flss, [r["labels_at_once"] / r["flss"] for r in spread], marker="o",
                     color="C0", label="mean, held at once")  # fmt: skip
    labels_axes.set_xlabel("FLSs (torus, 3 x the paper's spacing)")
    labels_axes.set_ylabel("labels an FLS holds in a phase")
    labels_axes.legend()
    memory_axes.plot(flss, [r["peak_mb"] for r in spread], marker="o", color="C0")
    memory_axes.set_xlabel("FLSs (torus, 3 x the paper's spacing)")
    memory_axes.set_ylabel("peak MB of the process (world, engine, discovery)")
    for axes in (labels_axes, memory_axes):
        axes.set_ylim(bottom=0)
        axes.grid(alpha=0.3)
    figure.suptitle("Labels by the search's reach: one in-memory discovery, every FLS a source")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda out: figure.savefig(out, dpi=110, format="png"))
