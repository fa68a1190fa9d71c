"""Every shape at display scale: plain Swazure, heuristics, fusion, the fit; 3,720-65,536 FLSs.

The `display` section of BENCHMARKS.md (`python -m bench --sections display`):
each run is one `swazure evaluate` process under an address-space cap, timed from
outside with its peak resident memory; where every pair of the swarm fits in memory
at once, the same run held whole (``--snapshot``, which holds every pair) is the
reference its pairs.csv and summary must equal byte for byte.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import resource
import subprocess
import tempfile
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

from bench.common import REPO, SECTIONS_DIR, SWAZURE
from swazure_ros.files.atomic import atomic_write
from swazure_ros.files.results import SUMMARY_FILE

#: The display's sizes, FLSs: the published race car's, and three display sizes.
DISPLAY_SIZES = (3720, 10000, 30000, 65536)
#: The shapes: a torus (every pair has a sweet path in sight) and the race car resampled
#: at its own spacing (3.4 % of its pairs need a decaying path at 65,536).
DISPLAY_SHAPES = ("torus", "racecar")
#: What each row runs: plain Swazure, each heuristic, fusion of three paths, the global fit.
DISPLAY_RUNS: dict[str, tuple[str, ...]] = {
    "plain": (),
    "move-obstructing": ("--technique", "move-obstructing"),
    "move-source": ("--technique", "move-source"),
    "fuse 3": ("--fuse", "3"),
    "least-squares": ("--estimator", "least-squares"),
}
#: The address space each run may take (the issue's cap), bytes.
ADDRESS_CAP = 16 * 2**30
#: The largest swarm whose held reference is run: every pair held at once (26 GB at 65,536).
HELD_UP_TO = 10000
#: How long one run may take before its row says it was stopped, s.
RUN_LIMIT_S = 3600.0


@dataclass(frozen=True)
class DisplayRow:
    """One run: what ran, how long, how much memory, and whether it equals the held run."""

    shape: str
    size: int
    run: str
    flss: int
    pairs: int
    wall: float
    peak_mb: float
    exit_code: int
    pairs_sha: str
    identical: str  # "yes", "NO", or "-" where no held run was made


def display_cloud(shape: str, size: int) -> tuple[str, ...]:
    """The cloud options of ``shape`` at ``size`` FLSs: a torus of that size, the published
    race car at 3,720, else the race car resampled to ``size``."""
    if shape == "torus":
        return ("--cloud", f"torus:{size}")
    if size == 3720:
        return ("--cloud", "racecar")
    return ("--cloud", "racecar", "--resample", str(size))


def _capped() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_CAP, ADDRESS_CAP))


def _timed(arguments: list[str], limit: float) -> tuple[float, float, int]:
    """Run under the address cap: wall s, peak RSS MB, exit code (-9: stopped at ``limit``)."""
    import os
    import threading

    began = time.perf_counter()
    process = subprocess.Popen(arguments, stdout=subprocess.DEVNULL, preexec_fn=_capped)
    stop = threading.Timer(limit, process.kill)
    stop.start()
    try:
        _, status, usage = os.wait4(process.pid, 0)
    finally:
        stop.cancel()
    # Reaped by wait4 (for its peak memory): tell the Popen, which would wait for it again.
    process.returncode = os.waitstatus_to_exitcode(status)
    return time.perf_counter() - began, usage.ru_maxrss / 1024, process.returncode


def _digest(path: Path) -> str:
    """sha256 of a file, read in blocks (pairs.csv is gigabytes at display scale)."""
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        while block := stream.read(1 << 24):
            digest.update(block)
    return digest.hexdigest()


def _comparable(document: object) -> object:
    """A JSON document as two runs of one work share it: without its "seconds", at any
    depth, and with the resampled cloud each run writes into its own folder named by its
    file name alone."""
    if isinstance(document, dict):
        return {
            key: Path(value).name if key == "cloud_source" and isinstance(value, str)
            else _comparable(value)
            for key, value in document.items()
            if key != "seconds"
        }  # fmt: skip
    return document


def summary_to_compare(path: Path) -> object:
    """summary.json as two runs of one work share it (:func:`_comparable`)."""
    return _comparable(json.loads(path.read_text()))


def display_run(
    shape: str,
    size: int,
    run: str,
    scratch_dir: Path = SECTIONS_DIR,
    held_up_to: int = HELD_UP_TO,
    options: Sequence[str] | None = None,
) -> DisplayRow:
    """One row: ``swazure evaluate`` of ``shape`` at ``size`` FLSs, as ``run`` asks (or
    ``options``, where given), beta 0.5; held as well where ``size`` is at most
    ``held_up_to``, and the two compared."""
    options = DISPLAY_RUNS[run] if options is None else options
    with tempfile.TemporaryDirectory(dir=scratch_dir) as scratch:
        blocked, held = Path(scratch) / "blocks", Path(scratch) / "held"
        command = [*SWAZURE, "evaluate", *display_cloud(shape, size), "--beta", "0.5",
                   *options, "--quiet"]  # fmt: skip
        print(f"bench: display {shape} {size} {run}", flush=True)
        wall, peak, code = _timed([*command, "--out", str(blocked)], RUN_LIMIT_S)
        summary_path = blocked / SUMMARY_FILE
        if code != 0 or not summary_path.exists():
            return DisplayRow(shape, size, run, 0, 0, wall, peak, code, "", "-")
        summary = json.loads(summary_path.read_text())
        sha = _digest(blocked / "pairs.csv")
        identical = "-"
        if size <= held_up_to:
            snapshot = Path(scratch) / "snapshot.png"
            _, _, held_code = _timed(
                [*command, "--out", str(held), "--snapshot", str(snapshot)], RUN_LIMIT_S
            )
            same = (
                held_code == 0
                and _digest(held / "pairs.csv") == sha
                and summary_to_compare(held / SUMMARY_FILE) == summary_to_compare(summary_path)
            )
            identical = "yes" if same else "NO"
    row = DisplayRow(shape, size, run, int(summary["flss"]), int(summary["blind_pairs"]), wall,
                     peak, code, sha, identical)  # fmt: skip
    print(f"bench: display {shape} {size} {run}: {wall:.1f} s, {peak:.0f} MB, "
          f"identical {identical}", flush=True)  # fmt: skip
    return row


def display_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = DISPLAY_SHAPES,
    sizes: Sequence[int] = DISPLAY_SIZES,
    runs: Sequence[str] = tuple(DISPLAY_RUNS),
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
    held_up_to: int = HELD_UP_TO,
) -> list[str]:
    """Every shape at display scale: the table, its targets and its figure.

    ``args.display_sizes``, where given, takes the place of ``sizes`` (a run of every size
    takes hours). The rows are recorded in display.json as each is made, so that a run
    stopped part way keeps what it measured.
    """
    sizes = getattr(args, "display_sizes", None) or sizes
    rows: list[DisplayRow] = []
    for size in sizes:
        for shape in shapes:
            for run in runs:
                rows.append(display_run(shape, size, run, records_dir, held_up_to))
                _record(rows, records_dir / "display.json")
    display_figure(rows, figures / "display-scale.png")
    return display_lines(rows)


def _record(rows: Sequence[DisplayRow], path: Path) -> None:
    """Write the rows made so far to ``path`` as JSON, atomically."""
    text = json.dumps([asdict(row) for row in rows], indent=1)
    atomic_write(path, lambda tmp: tmp.write_text(text))


def _cell(row: DisplayRow) -> list[str]:
    if row.exit_code != 0:
        stopped = "stopped at the limit" if row.exit_code == -9 else f"exit {row.exit_code}"
        return [f"{row.wall:.1f} ({stopped})", f"{row.peak_mb:.0f}", "-", "-"]
    return [f"{row.wall:.1f}", f"{row.peak_mb:.0f}", f"{row.pairs:,}", row.identical]


def display_lines(rows: Sequence[DisplayRow]) -> list[str]:
    """The display section of BENCHMARKS.md."""
    lines = [
        "## Every shape at display scale: plain Swazure, heuristics, fusion and the fit",
        "",
        "`swazure evaluate --beta 0.5 --out DIR` (pairs.csv and summary.json written),",
        f"default `--memory`, under a {ADDRESS_CAP // 2**30} GB address-space cap; wall time and",
        "peak resident memory of the process. The race car at 3,720 FLSs is the published cloud,",
        "at other sizes `--cloud racecar --resample N`. Identical: pairs.csv and summary.json",
        "(without timing) byte for byte those of the same run with every pair held at once",
        f"(`--snapshot`, the path every run took before blocks), made up to {HELD_UP_TO:,} FLSs.",
        "",
        "| shape | FLSs | run | wall s | peak MB | ordered blind pairs | identical to held |",
        "| --- | ---: | --- | ---: | ---: | ---: | --- |",
    ]
    for row in rows:
        size = f"{row.flss:,}" if row.flss else f"{row.size:,}"
        lines.append("| " + " | ".join([row.shape, size, row.run, *_cell(row)]) + " |")
    lines += ["", *display_targets(rows), "", "The plot is docs/figures/display-scale.png."]
    return lines


#: The issue's targets: (shape, size, run) -> (wall s, peak MB).
DISPLAY_TARGETS = {
    ("racecar", 65536, "plain"): (300.0, 8192.0),
    ("racecar", 65536, "move-obstructing"): (900.0, 8192.0),
    ("torus", 65536, "least-squares"): (600.0, 8192.0),
}


def display_targets(rows: Sequence[DisplayRow]) -> list[str]:
    """The targets, met or not, from the rows (a target whose run is absent says so)."""
    by = {(row.shape, row.size, row.run): row for row in rows}
    lines = ["Targets:", ""]
    for (shape, size, run), (wall, peak) in DISPLAY_TARGETS.items():
        name = (
            f"{shape} at {size:,} FLSs, {run}: under {wall / 60:.0f} min and {peak / 1024:.0f} GB"
        )
        row = by.get((shape, size, run))
        if row is None:
            lines.append(f"- {name}: not measured in this run.")
            continue
        met = row.exit_code == 0 and row.wall < wall and row.peak_mb < peak
        lines.append(
            f"- {name}: {row.wall:.0f} s, {row.peak_mb / 1024:.2f} GB"
            + ("" if row.exit_code == 0 else f" (exit {row.exit_code})")
            + f": {'met' if met else 'not met'}."
        )
    return lines


def display_figure(rows: Sequence[DisplayRow], path: Path) -> None:
    """Wall time and peak memory against FLSs, one line per run and shape."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    colours = dict(
        zip(DISPLAY_RUNS, plt.rcParams["axes.prop_cycle"].by_key()["color"], strict=False)
    )
    for shape, style in (("torus", "-o"), ("racecar", "--s")):
        for run in DISPLAY_RUNS:
            chosen = sorted(
                (
                    row
                    for row in rows
                    if row.shape == shape and row.run == run and row.exit_code == 0
                ),
                key=lambda row: row.size,
            )
            if not chosen:
                continue
            sizes = [row.size for row in chosen]
            label = f"{shape}, {run}"
            axes[0].plot(
                sizes, [row.wall for row in chosen], style, color=colours[run], label=label
            )
            axes[1].plot(sizes, [row.peak_mb / 1024 for row in chosen], style, color=colours[run],
                         label=label)  # fmt: skip
    axes[1].axhline(8, color="grey", linestyle=":", label="target at 65,536: 8 GB")
    axes[0].set_ylabel("wall time of swazure evaluate, s")
    axes[1].set_ylabel("peak resident memory, GB")
    for axis in axes:
        axis.set_xlabel("FLSs")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=7, ncol=2)
        axis.set_ylim(bottom=0)
    figure.suptitle(
        "Every shape at display scale: beta 0.5, pairs.csv written (torus solid, race car dashed)"
    )
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
