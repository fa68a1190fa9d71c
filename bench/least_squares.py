"""The least-squares fit beside Shortest-Length's paths: accuracy, NEES, outliers, cost.

The `least_squares` section of BENCHMARKS.md (`python -m bench --sections least_squares`).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import REPO, SECTIONS_DIR, SHAPES, run_output, swarm_cloud

FIT_BETAS = (0.3, 0.4, 0.5)


#: Sources whose own fits the least-squares section times, per shape.
LOCAL_SOURCES = 100


FIT_SENSORS = {
    "published": REPO / "config" / "sensor.yaml",
    "wide, calibrated": REPO / "config" / "cameras" / "sensor-wide-calibrated.yaml",
}


def least_squares_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = SHAPES,
    sensors: dict[str, Path] = FIT_SENSORS,
    betas: Sequence[float] = FIT_BETAS,
    local_sources: int = LOCAL_SOURCES,
    figures: Path = REPO / "docs" / "figures",
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The least-squares fit beside Shortest-Length's paths: accuracy, NEES, outliers, cost."""
    rows = []
    for shape in shapes:
        for sensor_name, sensor in sensors.items():
            for beta in betas:
                outliers = sensor_name != "published" and beta == 0.5
                extra = ["--outliers"] if outliers else []
                command = [sys.executable, "-m", "bench.measure_fit",
                           swarm_cloud(shape), "--beta", str(beta),
                           "--sensor", str(sensor), *extra]  # fmt: skip
                print(f"least squares: {shape} {sensor_name} beta {beta}", file=sys.stderr)
                _, memory, code, output = run_output(command)
                if code != 0:
                    raise SystemExit(f"measure_fit failed on {shape} {sensor_name} beta {beta}")
                result = json.loads(output)
                result.update(shape=shape, sensor=sensor_name, beta=beta, peak_mb=memory)
                rows.append(result)
    local_rows = []
    for shape in shapes:
        # One BLAS thread: an FLS solves on its own small processor.
        command = ["env", "OPENBLAS_NUM_THREADS=1", sys.executable,
                   "-m", "bench.measure_fit", swarm_cloud(shape),
                   "--beta", "0.5", "--sensor", str(FIT_SENSORS["wide, calibrated"]),
                   "--local", str(local_sources)]  # fmt: skip
        print(f"least squares: {shape}, {local_sources} sources' own fits", file=sys.stderr)
        _, _, code, output = run_output(command)
        if code != 0:
            raise SystemExit(f"measure_fit --local failed on {shape}")
        local_rows.append({"shape": shape, **json.loads(output)})
    (records_dir / "least-squares.json").write_text(
        json.dumps({"global": rows, "local": local_rows}, indent=1)
    )
    least_squares_figure(rows, figures)
    return least_squares_lines(rows, local_rows)


def least_squares_targets(
    rows: list[dict[str, Any]], local_rows: list[dict[str, Any]]
) -> list[str]:
    """Issue 33's targets, each against every measured cell: met in how many, the worst."""

    def worst(cells: list[tuple[str, float, float]], what: str) -> str:
        """cells: (where, value, limit); met where value < limit."""
        if not cells:  # a run of some shapes or sensors only (the smoke test's)
            return "0 of 0 | -"
        met = [value < limit for _, value, limit in cells]
        where, value, limit = max(cells, key=lambda c: c[1] / c[2] if c[2] else float("inf"))
        return (f"{sum(met)} of {len(met)} | worst: {where}, {value:.3g} against "
                f"{what} {limit:.3g}")  # fmt: skip

    def name(row: dict[str, Any]) -> str:
        return f"{row['shape']} {row['sensor']} {row['beta']}"

    stochastic = [row for row in rows if row["sensor"] != "published"]
    published = [row for row in rows if row["sensor"] == "published"]
    with_decaying = [row for row in rows if row["decaying"]["path"]["count"]]
    lines = [
        "Against issue 33's targets, over every cell above:",
        "",
        "| target | met | worst cell |",
        "| --- | --- | --- |",
        "| stochastic, sweet pairs: LS mean below one sweet hop's | "
        + worst([(name(r), r["sweet"]["fit"]["mean"], r["one_sweet_hop_pct"])
                 for r in stochastic], "one hop") + " |",
        "| stochastic, sweet pairs: LS p95 at most half SL's | "
        + worst([(name(r), r["sweet"]["fit"]["p95"], 0.5 * r["sweet"]["path"]["p95"] + 1e-12)
                 for r in stochastic], "half SL") + " |",
        "| decaying pairs: LS mean below SL's | "
        + worst([(name(r), r["decaying"]["fit"]["mean"], r["decaying"]["path"]["mean"])
                 for r in with_decaying], "SL") + " |",
        "| published, sweet pairs: LS mean not above SL's | "
        + worst([(name(r), r["sweet"]["fit"]["mean"], r["sweet"]["path"]["mean"] + 1e-12)
                 for r in published], "SL") + " |",
        "| published, sweet pairs: LS p95 below SL's | "
        + worst([(name(r), r["sweet"]["fit"]["p95"], r["sweet"]["path"]["p95"])
                 for r in published], "SL") + " |",
        "| stochastic: NEES mean within 3 +- 0.5 | "
        + worst([(name(r), abs(r["nees_mean"] - 3.0), 0.5 + 1e-12) for r in stochastic],
                "|NEES - 3|") + " |",
        "| stochastic: at least 93 % under 7.81 | "
        + worst([(name(r), 100.0 - r["within_chi2_95_pct"], 7.0 + 1e-12) for r in stochastic],
                "% over the bound") + " |",
        "| outliers: turned mean within 1.5x the clean | "
        + worst([(name(r), r["outliers"]["turned"]["mean"],
                  1.5 * r["outliers"]["clean"]["mean"] + 1e-12)
                 for r in rows if "outliers" in r], "1.5x clean") + " |",
        "| the same, pairs of FLSs in 2+ measured pairs | "
        + worst([(name(r), r["outliers"]["turned_redundant"]["mean"],
                  1.5 * r["outliers"]["clean_redundant"]["mean"] + 1e-12)
                 for r in rows if "turned_redundant" in r.get("outliers", {})], "1.5x clean")
        + " |",
        "| cost: the fit at most 0.5x the engine's time | "
        + worst([(name(r), r["fit_s"], 0.5 * r["engine_s"]) for r in rows], "half the engine's s")
        + " |",
        "| each source's own fit under 20 ms (race car) | "
        + worst([(r["shape"], r["ms"]["mean"], 20.0) for r in local_rows
                 if r["shape"].startswith("racecar")], "ms") + " |",
    ]  # fmt: skip
    return lines


def stat_cell(stats: dict[str, float], key: str) -> str:
    """An error statistic's cell, 2 decimals; "-" when absent or NaN."""
    value = stats[key]
    return "-" if value is None or value != value else f"{value:.2f}"


def trio(part: dict[str, Any]) -> str:
    """The mean errors by the path sums, the global fit and the source's own, as one cell."""
    return " / ".join(stat_cell(part[key], "mean") for key in ("path", "global", "local"))


def least_squares_lines(rows: list[dict[str, Any]], local_rows: list[dict[str, Any]]) -> list[str]:
    """The least-squares section of BENCHMARKS.md from bench.measure_fit's results."""

    lines = [
        "## Least-squares localization: `swazure evaluate --estimator least-squares`",
        "",
        "Shortest-Length's path sums (SL) beside the least-squares fit over every visible",
        "sweet measurement and the decaying hops that join sweet parts (LS; docs/core.md).",
        "Distance errors in %, mean / p95, on the pairs with a sweet path and on those that",
        "need a decaying hop; one sweet hop: the mean error of a single visible sweet",
        "measurement. NEES: the normalized estimation error squared (3 degrees of freedom),",
        "its mean and the share under the chi-square 95 % bound 7.81. Seconds: the engine's",
        "evaluation and the fit after it, in one process (bench/measure_fit.py).",
        "",
        "| shape | sensor | beta | one sweet hop | sweet SL | sweet LS | decaying SL | "
        "decaying LS | NEES mean | under 7.81 % | engine s | fit s | fit / engine |",
        "| --- | --- | ---: | ---: | --- | --- | --- | --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for row in rows:
        sweet, decaying = row["sweet"], row["decaying"]
        lines.append(
            f"| {row['shape']} | {row['sensor']} | {row['beta']} | "
            f"{row['one_sweet_hop_pct']:.2f} | "
            f"{stat_cell(sweet['path'], 'mean')} / {stat_cell(sweet['path'], 'p95')} | "
            f"{stat_cell(sweet['fit'], 'mean')} / {stat_cell(sweet['fit'], 'p95')} | "
            f"{stat_cell(decaying['path'], 'mean')} / {stat_cell(decaying['path'], 'p95')} | "
            f"{stat_cell(decaying['fit'], 'mean')} / {stat_cell(decaying['fit'], 'p95')} | "
            f"{row['nees_mean']:.2f} | {row['within_chi2_95_pct']:.1f} | "
            f"{row['engine_s']:.1f} | {row['fit_s']:.1f} | {row['fit_s'] / row['engine_s']:.2f} |"
        )
    lines += least_squares_outliers(rows)
    lines += least_squares_local(local_rows)
    lines += ["", *least_squares_targets(rows, local_rows)]
    lines += ["", "![least squares](docs/figures/least-squares.png)"]
    return lines


def least_squares_outliers(rows: list[dict[str, Any]]) -> list[str]:
    """The outliers table: each shape's errors clean and with 10 % of measurements turned."""
    lines = [
        "",
        "Outliers, wide calibrated sensor at beta 0.5: 10 % of the measurements turned by",
        "20 degrees about a random axis (`core.fit_measurements.with_outliers`), every pair",
        "with a path.",
        "",
        "| shape | clean mean / p95 % | turned mean / p95 % | turned / clean (mean) | "
        "the same, pairs of FLSs in 2+ measured pairs | down-weighted |",
        "| --- | --- | --- | ---: | --- | ---: |",
    ]
    for row in rows:
        if "outliers" in row:
            clean, turned = row["outliers"]["clean"], row["outliers"]["turned"]
            both = row["outliers"].get("clean_redundant"), row["outliers"].get("turned_redundant")
            redundant = (
                f"{stat_cell(both[0], 'mean')} -> {stat_cell(both[1], 'mean')} "
                f"({both[1]['mean'] / both[0]['mean']:.2f}x)"
                if both[0] and both[1]
                else "-"
            )
            lines.append(
                f"| {row['shape']} | {stat_cell(clean, 'mean')} / {stat_cell(clean, 'p95')} | "
                f"{stat_cell(turned, 'mean')} / {stat_cell(turned, 'p95')} | "
                f"{turned['mean'] / clean['mean']:.2f} | {redundant} | "
                f"{row['outliers']['downweighted']:,} |"
            )
    return lines


def least_squares_local(local_rows: list[dict[str, Any]]) -> list[str]:
    """The table of each source's own fit: its window, its time and its errors."""
    lines = [
        "",
        f"Each source's own fit (`--estimator local-least-squares`), {LOCAL_SOURCES} sources",
        "per shape drawn with seed 0, wide calibrated sensor, beta 0.5, one BLAS thread: the",
        "FLSs of its window (itself and its radio neighbours), the milliseconds of its fit,",
        "and the mean errors of its pairs by the path sums, the global fit and its own; pairs",
        "its window does not join to it take the path sum without the bias.",
        "",
        "| shape | window FLSs mean / max | ms per source mean / p95 / max | sweet % path / "
        "global / own | decaying % path / global / own | beyond the window |",
        "| --- | --- | --- | --- | --- | ---: |",
    ]
    for row in local_rows:
        ms, size = row["ms"], row["window_flss"]
        sweet, decaying = row["sweet"], row["decaying"]

        lines.append(
            f"| {row['shape']} | {size['mean']:.0f} / {size['max']} | "
            f"{ms['mean']:.0f} / {ms['p95']:.0f} / {ms['max']:.0f} | {trio(sweet)} | "
            f"{trio(decaying)} | {row['beyond_window']:,} |"
        )
    return lines


def least_squares_figure(rows: list[dict[str, Any]], folder: Path) -> None:
    """Mean errors of SL and LS per shape at beta 0.5, sweet and decaying pairs, per sensor."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from swazure_ros.files.atomic import atomic_write

    figure, axes = plt.subplots(2, 2, figsize=(12, 8), constrained_layout=True)
    for column, sensor in enumerate(FIT_SENSORS):
        chosen = [row for row in rows if row["sensor"] == sensor and row["beta"] == 0.5]
        names = [row["shape"] for row in chosen]
        x = list(range(len(chosen)))
        for line, kind in enumerate(("sweet", "decaying")):
            ax = axes[line][column]
            for offset, (estimator, label) in enumerate((("path", "Shortest-Length"),
                                                         ("fit", "least squares"))):  # fmt: skip
                values = [row[kind][estimator]["mean"] or 0.0 for row in chosen]
                ax.bar([v + 0.4 * offset - 0.2 for v in x], values, 0.4, label=label)
            if kind == "sweet":
                ax.plot(x, [row["one_sweet_hop_pct"] for row in chosen], "k_", markersize=18,
                        label="one sweet hop")  # fmt: skip
            drawn = [v for v in ax.get_ylim() if v > 0]
            largest = max((row[kind]["fit"]["mean"] or 1 for row in chosen), default=1)
            if largest * 10 < max(drawn, default=1):
                ax.set_yscale("log")  # the two estimators differ by orders of magnitude
            ax.set_xticks(x, names, rotation=20)
            ax.set_ylabel("mean distance error, %")
            ax.set_title(f"{sensor} sensor, beta 0.5: pairs with a {kind} path")
            ax.grid(True, axis="y", alpha=0.3)
            ax.legend(fontsize=8)
    folder.mkdir(parents=True, exist_ok=True)
    atomic_write(folder / "least-squares.png",
                 lambda tmp: figure.savefig(tmp, format="png", dpi=100))  # fmt: skip
