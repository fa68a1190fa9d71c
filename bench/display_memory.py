"""Peak memory against the swarm's size at one fixed `--memory` (issue 68: flat in N).

The `display_memory` section of BENCHMARKS.md (`python -m bench --sections
display_memory`): plain Swazure on the torus and the resampled race car at
10,000 to 65,536 FLSs, each one `swazure evaluate --memory 512M` process under
the display section's address cap, pairs.csv written; its peak resident memory
from wait4. Flat: the largest size's peak within FLAT_RATIO of the smallest's.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

from bench.common import REPO, SECTIONS_DIR
from bench.display import DISPLAY_SHAPES, DisplayRow, display_run
from swazure_ros.files.atomic import atomic_write

#: The budget every row runs at (issue 68's target names 512M).
FIXED_MEMORY = "512M"
#: The sizes, FLSs: from a display's smallest to its largest.
MEMORY_SIZES = (10000, 30000, 65536)
#: Peak at the largest size over the peak at the smallest, at most, to call it flat.
FLAT_RATIO = 1.2


def display_memory_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = DISPLAY_SHAPES,
    sizes: Sequence[int] = MEMORY_SIZES,
    figure: Path = REPO / "docs" / "figures" / "display-memory.png",
    scratch_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The rows, the verdict per shape and the figure of peak memory against FLSs."""
    rows = [
        display_run(shape, size, "plain", scratch_dir, 0, ("--memory", FIXED_MEMORY))
        for shape in shapes
        for size in sizes
    ]
    memory_figure(rows, figure)
    return memory_lines(rows)


def flat_verdict(rows: Sequence[DisplayRow], shape: str) -> str:
    """Whether ``shape``'s peak is flat from its smallest size to its largest, in one line."""
    done = sorted((row for row in rows if row.shape == shape), key=lambda row: row.size)
    if len(done) < 2 or any(row.exit_code != 0 for row in done):
        return f"- {shape}: not every size ran; not judged."
    first, last = done[0], done[-1]
    ratio = last.peak_mb / first.peak_mb
    verdict = "flat" if ratio <= FLAT_RATIO else "not flat"
    return (
        f"- {shape}: {first.peak_mb:,.0f} MB at {first.size:,} FLSs, {last.peak_mb:,.0f} MB at "
        f"{last.size:,}: {ratio:.2f}x, {verdict} (target: at most {FLAT_RATIO}x)."
    )


def memory_lines(rows: Sequence[DisplayRow]) -> list[str]:
    """The display_memory section of BENCHMARKS.md."""
    lines = [
        f"## Peak memory against the swarm's size at `--memory {FIXED_MEMORY}` (issue 68)",
        "",
        f"`swazure evaluate --beta 0.5 --memory {FIXED_MEMORY} --out DIR` (pairs.csv written),",
        "plain Swazure, under the display section's address cap; wall time and peak resident",
        "memory of the process. The race car is `--cloud racecar --resample N`.",
        "",
        "| shape | FLSs | wall s | peak MB | ordered blind pairs |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        done = row.exit_code == 0
        wall = f"{row.wall:.1f}" if done else f"{row.wall:.1f} (exit {row.exit_code})"
        pairs = f"{row.pairs:,}" if done else "-"
        flss = f"{row.flss:,}" if done else f"{row.size:,}"  # a torus has about the size asked
        lines.append(f"| {row.shape} | {flss} | {wall} | {row.peak_mb:,.0f} | {pairs} |")
    lines += ["", "Flat in N:", ""]
    lines += [flat_verdict(rows, shape) for shape in dict.fromkeys(row.shape for row in rows)]
    lines += ["", "The plot is docs/figures/display-memory.png."]
    return lines


def memory_figure(rows: Sequence[DisplayRow], path: Path) -> None:
    """Peak resident memory against FLSs, one line per shape, the smallest's level dotted."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    for shape, style in (("torus", "-o"), ("racecar", "--s")):
        done = sorted(
            (row for row in rows if row.shape == shape and row.exit_code == 0),
            key=lambda row: row.size,
        )
        if not done:
            continue
        line = axis.plot(
            [row.size for row in done], [row.peak_mb for row in done], style, label=shape
        )
        axis.axhline(
            done[0].peak_mb * FLAT_RATIO, color=line[0].get_color(), linestyle=":", alpha=0.6,
            label=f"{shape}: flat ({FLAT_RATIO}x its smallest)",
        )  # fmt: skip
    axis.set_xlabel("FLSs")
    axis.set_ylabel("peak resident memory, MB")
    axis.set_ylim(bottom=0)
    axis.grid(alpha=0.3)
    axis.legend(fontsize=8)
    axis.set_title(f"Peak memory at --memory {FIXED_MEMORY}: plain Swazure, pairs.csv written")
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
