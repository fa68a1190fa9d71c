"""The swarm's own solve of the least-squares fit beside the central one, on every shape.

The `swarm_solve` section of BENCHMARKS.md (`python -m bench --sections swarm_solve`).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import (
    REPO,
    RUN_LIMIT,
    SECTIONS_DIR,
    SHAPES,
    compute_all,
    run_output,
    swarm_cloud,
)
from bench.least_squares import FIT_BETAS, FIT_SENSORS

#: Shapes beyond the published six whose swarm solve alone is measured (the central fit's
#: dense covariance of 30,000 unknowns would not be worth its minutes).
SWARM_SOLVE_LARGE = ("torus:10000",)


#: Shapes whose swarm of FLS nodes solves its fit, one process, beside a plain run.
SWARM_SOLVE_PACKED = ("chess_408", "dragon_1147", "racecar_3720")


def swarm_solve_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = SHAPES,
    sensors: dict[str, Path] = FIT_SENSORS,
    betas: Sequence[float] = FIT_BETAS,
    large: Sequence[str] = SWARM_SOLVE_LARGE,
    packed_shapes: Sequence[str] = SWARM_SOLVE_PACKED,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The swarm's own solve of the least-squares fit beside the central one, on every shape."""
    rows = []
    for shape in shapes:
        for sensor_name, sensor in sensors.items():
            for beta in betas:
                extra = []
                if sensor_name != "published" and beta == 0.5:
                    extra = ["--outliers", "--warm"]
                command = [sys.executable, "-m", "bench.measure_swarm_solve",
                           swarm_cloud(shape), "--beta", str(beta),
                           "--sensor", str(sensor), *extra]  # fmt: skip
                print(f"swarm solve: {shape} {sensor_name} beta {beta}", file=sys.stderr)
                _, memory, code, output = run_output(command)
                if code != 0:
                    raise SystemExit(f"measure_swarm_solve failed on {shape} {sensor_name} {beta}")
                result = json.loads(output)
                result.update(shape=shape, sensor=sensor_name, beta=beta, peak_mb=memory)
                rows.append(result)
    for shape in large:
        command = [sys.executable, "-m", "bench.measure_swarm_solve", shape,
                   "--beta", "0.5", "--sensor", str(FIT_SENSORS["wide, calibrated"]),
                   "--no-central", "--warm"]  # fmt: skip
        print(f"swarm solve: {shape}, the swarm's solve alone", file=sys.stderr)
        _, memory, code, output = run_output(command)
        if code != 0:
            raise SystemExit(f"measure_swarm_solve failed on {shape}")
        result = json.loads(output)
        result.update(shape=shape, sensor="wide, calibrated", beta=0.5, peak_mb=memory)
        rows.append(result)
    packed = swarm_solve_packed(packed_shapes)
    (records_dir / "swarm-solve.json").write_text(
        json.dumps({"rows": rows, "packed": packed}, indent=1)
    )
    swarm_solve_figure(rows, figures / "swarm-solve.png")
    return swarm_solve_lines(rows, packed)


def swarm_solve_packed(shapes: Sequence[str] = SWARM_SOLVE_PACKED) -> list[dict[str, Any]]:
    """`spawn --compute-all` of a few shapes in one process: plain paths, then the swarm's fit."""
    sensor = str(FIT_SENSORS["wide, calibrated"])
    rows = []
    for name in shapes:
        for estimator in ("path", "swarm-fit"):
            with tempfile.TemporaryDirectory() as out:
                row = compute_all(
                    swarm_cloud(name), "plain", 94, Path(out), 1, RUN_LIMIT["plain"],
                    "--sensor", sensor, "--estimator", estimator,
                )  # fmt: skip
            print(f"swarm solve, packed: {name} {estimator}: {row}", file=sys.stderr)
            rows.append({"shape": name, "estimator": estimator, **row})
    return rows


def mean_cell(fit: dict[str, Any] | None, part: str) -> str:
    """A fit's mean error on ``part`` (sweet or decaying pairs), 3 digits; "-" when none."""
    if fit is None or not fit[part]["count"]:
        return "-"
    return f"{fit[part]['mean']:.3g}"


def swarm_over_central(row: dict[str, Any], part: str) -> float:
    """The swarm's mean error on ``part`` over the central fit's; NaN when not measured."""
    if "central" not in row or not row["central"][part]["count"]:
        return float("nan")
    return float(row["swarm"][part]["mean"] / row["central"][part]["mean"])


def swarm_solve_lines(rows: list[dict[str, Any]], packed: list[dict[str, Any]]) -> list[str]:
    """The swarm solve's section of BENCHMARKS.md from bench.measure_swarm_solve's results."""

    lines = [
        "## The swarm's own least-squares fit: `--estimator swarm-fit`",
        "",
        "The central fit (LS, `--estimator least-squares`) beside the same fit solved as the",
        "swarm solves it (SW, `core.swarm_fit`: block-Jacobi conjugate gradients, one exchange",
        "with the measured neighbours and one exact sum over the swarm per iteration; its",
        f"covariance from {rows[0]['samples']} sampled right sides). Distance errors in %, mean,",
        "on the pairs with a sweet path and on those that need a decaying hop; NEES: the",
        "normalized estimation error squared, mean (3 is honest; the published sensor's errors",
        "are a bias, so its NEES measures nothing). Iterations: the fit's solves (the fit and",
        "the robust loss's reweightings) + the covariance's, each to a residual 1e-10 of its",
        "right side's; the published sensor has two fits (the sweet hops alone for the sweet",
        "pairs, with the joining decaying hops for the others; docs/core.md), separated by ;.",
        "Diameter: the fit graph's, in hops. FLS us: one FLS's work in one iteration of the",
        "covariance's solve (its three rows of H times 64 columns, and its block), mean / max",
        "over 200 FLSs. Engine s: the",
        "plain evaluation; SW s: the engine's run of the swarm's solve after it, one process",
        "(bench/measure_swarm_solve.py).",
        "",
        "| shape | sensor | beta | sweet LS / SW | decaying LS / SW | SW / LS (sweet, decaying) "
        "| NEES LS / SW | iterations | diameter | FLS us | engine s | LS s | SW s |",
        "| --- | --- | ---: | --- | --- | --- | --- | --- | ---: | --- | ---: | ---: | ---: |",
    ]
    lines += [swarm_solve_row(row) for row in rows]
    lines += swarm_solve_warm(rows)
    lines += swarm_solve_outliers(rows)
    lines += swarm_solve_packed_lines(packed)
    lines += [
        "",
        *swarm_solve_targets(rows, packed),
        "",
        "![swarm solve](docs/figures/swarm-solve.png)",
    ]
    return lines


def swarm_solve_row(row: dict[str, Any]) -> str:
    """One row of the main table: a shape, sensor and beta's fits, their costs."""
    central, swarm = row.get("central"), row["swarm"]
    solves = " ; ".join(f"{'+'.join(map(str, one[:-1]))} + {one[-1]}" for one in row["iterations"])
    nees = " / ".join(
        "-" if fit is None else f"{fit['nees_mean']:.2f}" for fit in (central, swarm)
    )
    central_s = "-" if row["central_s"] is None else f"{row['central_s']:.1f}"
    return (
        f"| {row['shape']} | {row['sensor']} | {row['beta']} | "
        f"{mean_cell(central, 'sweet')} / {mean_cell(swarm, 'sweet')} | "
        f"{mean_cell(central, 'decaying')} / {mean_cell(swarm, 'decaying')} | "
        f"{swarm_over_central(row, 'sweet'):.4f}, "
        f"{swarm_over_central(row, 'decaying'):.4f} | {nees} | "
        f"{solves} | "
        f"{row['diameter_hops']} | {row['fls_work_us']['mean']:.0f} / "
        f"{row['fls_work_us']['max']:.0f} | {row['engine_s']:.1f} | {central_s} | "
        f"{row['swarm_s']:.1f} |"
    )


def swarm_solve_warm(rows: list[dict[str, Any]]) -> list[str]:
    """The warm-start table: iterations cold and warm after FLSs depart or move."""
    lines = [
        "",
        "Moving and failing FLSs, wide calibrated sensor at beta 0.5: iterations of the first",
        "solve from nothing, and from the last fit's positions (a warm start) after 1 % of the",
        "FLSs depart (their measurements gone) or move 0.5 cm each (their measurements follow).",
        "",
        "| shape | FLSs | cold | departed: cold / warm | moved: warm |",
        "| --- | ---: | ---: | --- | ---: |",
    ]
    for row in rows:
        if "warm" in row:
            warm = row["warm"]
            lines.append(
                f"| {row['shape']} | {row['flss']:,} | {warm['cold']} | "
                f"{warm['departed_cold']} / {warm['departed_warm']} | {warm['moved_warm']} |"
            )
    return lines


def swarm_solve_outliers(rows: list[dict[str, Any]]) -> list[str]:
    """The outliers table: each fit's error clean and with 10 % of measurements turned."""
    lines = [
        "",
        "Outliers, wide calibrated sensor at beta 0.5: 10 % of the measurements turned by 20",
        "degrees (`core.fit_measurements.with_outliers`, seed 1); mean distance error, %, of",
        "every pair with a path and of the pairs of FLSs in two or more measured pairs.",
        "",
        "| shape | LS clean -> turned | SW clean -> turned | SW, 2+ pairs: clean -> turned "
        "(ratio) | down-weighted LS / SW |",
        "| --- | --- | --- | --- | --- |",
    ]
    for row in rows:
        if "outliers" in row:
            central, swarm = row["outliers"]["central"], row["outliers"]["swarm"]
            redundant = swarm["turned_redundant"]["mean"] / swarm["clean_redundant"]["mean"]
            lines.append(
                f"| {row['shape']} | {central['clean']['mean']:.3g} -> "
                f"{central['turned']['mean']:.3g} | {swarm['clean']['mean']:.3g} -> "
                f"{swarm['turned']['mean']:.3g} | {swarm['clean_redundant']['mean']:.3g} -> "
                f"{swarm['turned_redundant']['mean']:.3g} ({redundant:.2f}x) | "
                f"{central['downweighted']:,} / {swarm['downweighted']:,} |"
            )
    return lines


def swarm_solve_packed_lines(packed: list[dict[str, Any]]) -> list[str]:
    """The table of the swarm of FLS nodes solving the fit, beside its plain run."""
    lines = [
        "",
        "The swarm of FLS nodes solving it, one process (`spawn --compute-all --estimator",
        "swarm-fit`, wide calibrated sensor, beta 0.5), beside the same swarm's plain run:",
        "discovery s is the whole run, discovery's phases and then the FIT phase; the fit's",
        "share is the difference. Identical: every estimate to 1e-9 cm and every covariance to",
        "1e-9 of its largest entry, against the engine's `--estimator swarm-fit`.",
        "",
        "| shape | estimator | discovery s | rounds | messages | engine s | identical | peak MB |",
        "| --- | --- | ---: | ---: | ---: | ---: | --- | ---: |",
    ]
    for row in packed:
        if "failed" in row:
            lines.append(f"| {row['shape']} | {row['estimator']} | {row['failed']} |" + " |" * 5)
            continue
        lines.append(
            f"| {row['shape']} | {row['estimator']} | {row['discovery']:.1f} | {row['rounds']} "
            f"| {row['messages']:,} | {row['engine']:.1f} | {row['identical']} | {row['peak']} |"
        )
    return lines


def swarm_solve_targets(rows: list[dict[str, Any]], packed: list[dict[str, Any]]) -> list[str]:
    """Issue 54's targets that the engine's run measures, each over every row."""

    def verdict(values: list[tuple[str, float]], limit: float, below: bool = True) -> str:
        met = [value <= limit if below else value >= limit for _, value in values]
        worst = max(values, key=lambda item: item[1] if below else -item[1])
        return f"{sum(met)} of {len(met)} | {worst[0]}: {worst[1]:.4g} |"

    def name(row: dict[str, Any]) -> str:
        return f"{row['shape']} {row['sensor']} {row['beta']}"

    central = [row for row in rows if "central" in row]
    stochastic = [row for row in rows if row["sensor"] != "published"]
    ratios = [
        (f"{name(row)} {part}", row["swarm"][part]["mean"] / row["central"][part]["mean"])
        for row in central
        for part in ("sweet", "decaying")
        if row["central"][part]["count"]
    ]
    nees = [(name(row), abs(row["swarm"]["nees_mean"] - 3.0)) for row in stochastic]
    work = [(name(row), row["fls_work_us"]["max"] / 1000.0) for row in rows]
    engine = [(name(row), row["swarm_s"] / row["engine_s"]) for row in rows]
    outliers = [
        (row["shape"], row["outliers"]["swarm"]["turned_redundant"]["mean"]
         / row["outliers"]["swarm"]["clean_redundant"]["mean"])
        for row in rows if "outliers" in row
    ]  # fmt: skip
    return [
        "Against issue 54's targets that the engine's run measures (met in how many rows; the",
        "worst row):",
        "",
        "| target | met | worst |",
        "| --- | --- | --- |",
        "| SW mean error within 1.2x LS's, sweet and decaying pairs | " + verdict(ratios, 1.2),
        "| stochastic: SW's NEES mean within 3 +- 0.5 | " + verdict(nees, 0.5),
        "| one FLS's iteration under 1 ms (max, ms) | " + verdict(work, 1.0),
        "| the engine's run of SW within the engine's evaluation time (ratio) | "
        + verdict(engine, 1.0),
        "| outliers: pairs of FLSs in 2+ measured pairs within 1.5x clean | "
        + verdict(outliers, 1.5),
        f"| one message per FLS and iteration of at most a few kB | {len(rows)} of {len(rows)} "
        f"| {rows[0]['message_bytes']['samples']:,} bytes (the covariance's solve) |",
        "| the race car's fit by its swarm, packed, under 60 s (the fit's share, s) | "
        + _packed_fit_share(packed, "racecar_3720"),
    ]


def _packed_fit_share(packed: list[dict[str, Any]], shape: str) -> str:
    """met or not, and the seconds of the FIT phase: swarm-fit's discovery less the path's."""
    runs = {row["estimator"]: row for row in packed if row["shape"] == shape}
    if any("failed" in row for row in runs.values()) or len(runs) < 2:
        return "not measured | - |"
    share = runs["swarm-fit"]["discovery"] - runs["path"]["discovery"]
    return f"{'1 of 1' if share < 60 else '0 of 1'} | {shape}: {share:.1f} |"


def swarm_solve_figure(rows: list[dict[str, Any]], path: Path) -> None:
    """Iterations of the swarm's first solve and of its covariance's against the diameter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from swazure_ros.files.atomic import atomic_write

    figure, axes = plt.subplots(1, 2, figsize=(12, 4.8), constrained_layout=True)
    for axis, sensor in zip(axes, FIT_SENSORS, strict=True):
        chosen = [row for row in rows if row["sensor"] == sensor]
        for beta, marker in zip(FIT_BETAS, "o^sD", strict=False):
            at = [row for row in chosen if row["beta"] == beta]
            diameter = [row["diameter_hops"] for row in at]
            # The last fit's (with the joining hops): its first solve and the covariance's.
            axis.scatter(diameter, [row["iterations"][-1][0] for row in at], marker=marker,
                         color="tab:blue", label=f"fit, beta {beta}")  # fmt: skip
            axis.scatter(diameter, [row["iterations"][-1][-1] for row in at], marker=marker,
                         color="tab:orange", label=f"covariance, beta {beta}")  # fmt: skip
            for row in at:
                axis.annotate(row["shape"].split("_")[0], (row["diameter_hops"],
                              row["iterations"][-1][0]), fontsize=7)  # fmt: skip
        axis.set_xlabel("diameter of the fit graph, hops")
        axis.set_ylabel("iterations to settle (residual 1e-10 of the right side's)")
        axis.set_title(f"{sensor} sensor")
        axis.grid(alpha=0.3)
        axis.legend(fontsize=7)
    figure.suptitle("The swarm's solve: iterations against the measurement graph's diameter")
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=110))
