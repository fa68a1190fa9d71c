"""The engine at display scale: time and memory from 3,720 to 65,536 FLSs.

The `scale` section of BENCHMARKS.md (`python -m bench --sections scale`).
"""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import DATASETS, REPO, SECTIONS_DIR, SHAPES, SWAZURE, run_output
from swazure_ros.files.results import SUMMARY_FILE
from swazure_ros.files.runs import read_summary

#: The scale table's clouds: the published race car, tori of growing size, display-size
#: shapes, and the race car resampled to a display's 65,536 FLSs at the paper's spacing.
SCALE_CLOUDS = ["racecar_3720", "torus:10000", "torus:30000", "torus:65536",
                "sphere_shell:65536", "racecar_65536"]  # fmt: skip


#: The budget at which memory should stay flat as the swarm grows.
SCALE_FIXED_MEMORY = "512M"
#: The clouds the section also evaluates at SCALE_FIXED_MEMORY.
SCALE_FIXED_CLOUDS = ("racecar_3720", "torus:10000", "torus:30000", "torus:65536")


#: The published race car's time before blocks (BENCHMARKS.md, "Core engine").
RACE_CAR_BEFORE_S = (14.0, 16.0)


def scale_cloud(name: str) -> str:
    """The --cloud of a scale cloud: a built-in shape, a published file, or a resampled file."""
    if ":" in name:
        return name
    if name == "racecar_65536":
        from swazure_ros.core.clouds import resample
        from swazure_ros.files.cloud_files import load_cloud

        path = SECTIONS_DIR / "racecar_65536.xyz"
        if not path.exists():
            import numpy as np

            source = load_cloud(DATASETS / "racecar_3720.xyz")
            print("bench: resampling the race car to 65,536 points", flush=True)
            np.savetxt(path, resample(source.points, 65536), fmt="%.9f")
        return str(path)
    return str(DATASETS / f"{name}.xyz")


def scale_run(name: str, memory: str | None, scratch_dir: Path = SECTIONS_DIR) -> dict[str, Any]:
    """``swazure evaluate`` of one scale cloud at beta 0.5: wall, peak, summary, pairs.csv size."""
    with tempfile.TemporaryDirectory(dir=scratch_dir) as scratch:
        options = [] if memory is None else ["--memory", memory]
        wall, peak, code, _ = run_output(
            [*SWAZURE, "evaluate", "--cloud", scale_cloud(name), "--beta", "0.5", "--quiet",
             "--out", scratch, *options]
        )  # fmt: skip
        if code != 0:
            raise SystemExit(f"bench: evaluate {name} {options} failed with exit code {code}")
        summary = read_summary(Path(scratch) / SUMMARY_FILE)
        csv_bytes = (Path(scratch) / "pairs.csv").stat().st_size
    pairs = summary.pairs
    row = {"cloud": name, "memory": memory or "default", "wall": wall, "peak": peak,
           "engine": summary.seconds, "flss": summary.flss,
           "pairs": pairs.blind_pairs, "sweet_pct": pairs.sweet_pct,
           "quantiles": pairs.as_document()["quantiles"], "csv_bytes": csv_bytes}  # fmt: skip
    print(f"bench: scale {name} {row['memory']}: {wall:.1f} s, {peak:.0f} MB", flush=True)
    return row


def scale_identity(
    shapes: Sequence[str] = SHAPES, scratch_dir: Path = SECTIONS_DIR
) -> list[tuple[str, bool, bool]]:
    """Each published shape: pairs.csv (and .parquet) in blocks, byte for byte the whole path's."""
    from swazure_ros.core.blocks import Budget, evaluate_blocked
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.core.progress import SILENT
    from swazure_ros.files.cloud_files import load_cloud
    from swazure_ros.files.results import write_evaluation, write_pair_blocks
    from swazure_ros.files.sensors import load_sensor

    sensor, found = load_sensor(), list[tuple[str, bool, bool]]()
    for shape in shapes:
        swarm = make_swarm(load_cloud(scale_cloud(shape)).points, beta=0.5)
        whole = evaluate(swarm, sensor, "shortest-length")
        same = []
        for pairs_format in ("csv", "parquet"):
            with tempfile.TemporaryDirectory(dir=scratch_dir) as scratch:
                at_once, blocked = Path(scratch) / "whole", Path(scratch) / "blocks"
                at_once.mkdir()
                blocked.mkdir()
                _, expected = write_evaluation(at_once, whole, None, pairs_format)
                assert expected is not None  # csv and parquet write a file
                # 64 MiB: the race car's pairs in about 80 blocks.
                run = evaluate_blocked(
                    swarm, sensor, "shortest-length", Budget(64 * 2**20), SILENT
                )
                got = write_pair_blocks(blocked, run.hood, run.policy, run.blocks(SILENT),
                                        pairs_format)  # fmt: skip
                assert got is not None
                same.append(got.read_bytes() == expected.read_bytes())
        found.append((shape, same[0], same[1]))
        print(f"bench: scale identity {shape}: {same}", flush=True)
    return found


def scale_section(
    args: argparse.Namespace,
    clouds: Sequence[str] = SCALE_CLOUDS,
    fixed_clouds: Sequence[str] = SCALE_FIXED_CLOUDS,
    identity_shapes: Sequence[str] = SHAPES,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The engine at display scale: time and memory from 3,720 to 65,536 FLSs."""
    rows = [scale_run(name, None, records_dir) for name in clouds]
    rows += [scale_run(name, SCALE_FIXED_MEMORY, records_dir) for name in fixed_clouds]
    identity = scale_identity(identity_shapes, records_dir)
    (records_dir / "scale.json").write_text(json.dumps({"rows": rows, "identity": identity},
                                                       indent=1))  # fmt: skip
    scale_figure(rows, figures / "engine-scale.png")
    return scale_lines(rows, identity)


def scale_lines(rows: list[dict[str, Any]], identity: list[tuple[str, bool, bool]]) -> list[str]:
    """The scale section of BENCHMARKS.md."""
    lines = [
        "## The engine at display scale: `swazure evaluate` from 3,720 to 65,536 FLSs",
        "",
        "Plain Swazure at beta 0.5, the default policy and sensor, pairs.csv and summary.json",
        "written (`swazure evaluate --out`). Wall time and peak resident",
        "memory of the whole process; engine s is summary.json's (neighbourhood and pairs,",
        "without writing). `--memory` bounds a block's work (default 2G); the swarm's sweet",
        "pairs (and, when a pair needs them, its decaying pairs in sight) are held whole.",
        "racecar_65536 is the race car resampled to 65,536 points at its own mean spacing",
        "(`core.clouds.resample`).",
        "",
        "| cloud | FLSs | ordered blind pairs | --memory | wall s | engine s | peak MB "
        "| s per M pairs (wall) | sweet % | pairs.csv GB | quantiles |",
        "| --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | --- |",
    ]
    for row in rows:
        lines.append(
            f"| {row['cloud']} | {row['flss']:,} | {row['pairs']:,} | {row['memory']} "
            f"| {row['wall']:.1f} | {row['engine']:.1f} | {row['peak']:.0f} "
            f"| {row['wall'] / max(row['pairs'], 1) * 1e6:.2f} | {row['sweet_pct']:.2f} "
            f"| {row['csv_bytes'] / 1e9:.2f} | {row['quantiles']} |"
        )
    lines += [
        "",
        "pairs.csv and pairs.parquet of each published shape (shortest-length), written in",
        "blocks of a 64 MiB budget, against the same files written from the whole evaluation:",
        "",
        "| shape | pairs.csv identical | pairs.parquet identical |",
        "| --- | --- | --- |",
        *[
            f"| {shape} | {'yes' if csv else 'NO'} | {'yes' if parquet else 'NO'} |"
            for shape, csv, parquet in identity
        ],
        "",
        *scale_targets(rows),
        "",
        "The plot is docs/figures/engine-scale.png.",
    ]
    return lines


def scale_targets(rows: list[dict[str, Any]]) -> list[str]:
    """Issue 51's targets, met or not, from the rows."""
    by = {(row["cloud"], row["memory"]): row for row in rows}
    torus, car = by[("torus:65536", "default")], by[("racecar_3720", "default")]
    fixed = [by[(name, SCALE_FIXED_MEMORY)] for name in ("torus:10000", "torus:30000",
                                                         "torus:65536")]  # fmt: skip
    per_pair = [row["wall"] / row["pairs"] for row in (car, torus)]
    met = torus["wall"] < 300 and torus["peak"] < 8192
    car_display = by[("racecar_65536", "default")]
    car_met = car_display["wall"] < 300 and car_display["peak"] < 8192
    return [
        "Targets:",
        "",
        f"- torus:65536 in under 5 minutes and 8 GB: {torus['wall']:.0f} s, "
        f"{torus['peak'] / 1024:.2f} GB: {'met' if met else 'not met'}.",
        f"- racecar_65536 in under 5 minutes and 8 GB: {car_display['wall']:.0f} s, "
        f"{car_display['peak'] / 1024:.2f} GB: {'met' if car_met else 'not met'}.",
        f"- Per pair at 65,536 FLSs within 1.5x of the race car's: "
        f"{per_pair[1] * 1e6:.2f} against {per_pair[0] * 1e6:.2f} s per million pairs "
        f"({per_pair[1] / per_pair[0]:.2f}x).",
        f"- Memory at --memory {SCALE_FIXED_MEMORY} from 10,000 to 65,536 FLSs: "
        + ", ".join(f"{row['peak']:.0f}" for row in fixed)
        + " MB.",
        f"- The race car no slower than before blocks ({RACE_CAR_BEFORE_S[0]:.0f}-"
        f"{RACE_CAR_BEFORE_S[1]:.0f} s): {car['wall']:.1f} s.",
    ]


def scale_figure(rows: list[dict[str, Any]], path: Path) -> None:
    """Wall time and peak memory against FLSs, at the default budget and at a fixed one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from swazure_ros.files.atomic import atomic_write

    figure, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    for memory, style in (("default", "-o"), (SCALE_FIXED_MEMORY, "--s")):
        chosen = [row for row in rows if row["memory"] == memory]
        tori = sorted((row for row in chosen if row["cloud"].startswith("torus")),
                      key=lambda row: row["flss"])  # fmt: skip
        label = f"torus, --memory {'2G (default)' if memory == 'default' else memory}"
        axes[0].plot([row["flss"] for row in tori], [row["wall"] for row in tori], style,
                     label=label)  # fmt: skip
        axes[1].plot([row["flss"] for row in tori], [row["peak"] / 1024 for row in tori], style,
                     label=label)  # fmt: skip
    for row in rows:
        if row["memory"] == "default" and not row["cloud"].startswith("torus"):
            for axis, value in zip(axes, (row["wall"], row["peak"] / 1024), strict=True):
                axis.scatter([row["flss"]], [value], marker="D", zorder=3)
                axis.annotate(row["cloud"], (row["flss"], value), fontsize=8,
                              textcoords="offset points", xytext=(4, 4))  # fmt: skip
    axes[0].axhline(300, color="grey", linestyle=":", label="target at 65,536: 5 min")
    axes[1].axhline(8, color="grey", linestyle=":", label="target at 65,536: 8 GB")
    axes[0].set_ylabel("wall time of swazure evaluate, s")
    axes[1].set_ylabel("peak resident memory, GB")
    for axis in axes:
        axis.set_xlabel("FLSs")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8)
        axis.set_ylim(bottom=0)
    figure.suptitle("The engine at display scale: plain Swazure, beta 0.5, pairs.csv written")
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
