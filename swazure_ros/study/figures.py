"""The study's figures (spec, section 10) as PNG files, drawn with matplotlib's Agg canvas.

Figures are built on ``matplotlib.figure.Figure`` rather than pyplot, so no
global figure state is kept between calls. Each shape has one colour, the
same in every figure (its position in the plan, in the tab10 palette).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..core.errors import SwazureError
from ..core.evaluate import evaluate
from ..core.geometry import make_swarm
from ..core.summary import Summary
from ..files.atomic import atomic_write
from ..files.reading import CONFIG_BYTES, read_text
from ..files.results import read_pairs
from ..view.png import save
from ..view.scene import evaluation_scene
from ..view.snapshot import write_snapshot
from .plan import FIT, PLAIN_TECHNIQUE, StudyPlan, Technique
from .sweep import SweepResult

POLICY_TITLES = {
    "fewest-hops": "Fewest-Hops",
    "shortest-length": "Shortest-Length",
    "least-error": "Least-Error",
}
BETA_LABEL = "β (FLS radius r = β · dmin)"


def shape_colours(plan: StudyPlan) -> dict[str, Any]:
    """One tab10 colour per shape, by its place in the plan."""
    from matplotlib import colormaps

    palette = colormaps["tab10"]
    return {cloud.name: palette(index % 10) for index, cloud in enumerate(plan.clouds)}


def _panels(plan: StudyPlan, fused: bool = False) -> list[tuple[str, str, Technique]]:
    """(title, policy, technique) of each panel: plain Swazure per policy, then the
    study's other estimators (fused, least squares) when ``fused``."""
    panels = [(POLICY_TITLES.get(p, p), p, PLAIN_TECHNIQUE) for p in plan.policies]
    if fused:
        policy = plan.heuristic_policy
        for estimator in plan.estimators:
            title = f"{POLICY_TITLES.get(policy, policy)}, {estimator.title}"
            panels.append((title, policy, estimator))
    return panels


def _per_policy_axes(
    plan: StudyPlan, title: str, fused: bool = False
) -> tuple[Figure, list[Axes]]:
    panels = _panels(plan, fused)
    figure = Figure(figsize=(5.5 * len(panels) + 2.0, 4.6), layout="constrained")
    axes = figure.subplots(1, len(panels), sharey=True, squeeze=False)[0]
    figure.suptitle(title)
    for ax, (panel_title, _, _) in zip(axes, panels, strict=True):
        ax.set_title(panel_title)
        ax.grid(True, alpha=0.3)
    return figure, list(axes)


def _legend(figure: Figure, axes: Sequence[Axes]) -> None:
    handles, labels = axes[0].get_legend_handles_labels()
    figure.legend(handles, labels, title="shape", loc="outside right center")


def metric_vs_beta(
    plan: StudyPlan,
    result: SweepResult,
    value: Callable[[Summary], float | None],
    title: str,
    ylabel: str,
    log: bool = False,
    fused: bool = False,
) -> Figure:
    """One line per shape of ``value(summary)`` against beta, one panel per policy.

    ``fused``: one more panel, the study's fused runs (when it has them).
    """
    colours = shape_colours(plan)
    figure, axes = _per_policy_axes(plan, title, fused)
    for ax, (_, policy, technique) in zip(axes, _panels(plan, fused), strict=True):
        for cloud in plan.clouds:
            points = []
            for beta in sorted(plan.betas):
                summary = result.find(cloud.name, beta, policy, technique)
                y = None if summary is None else value(summary)
                if y is not None:
                    points.append((beta, y))
            if points:
                xs, ys = zip(*points)
                ax.plot(xs, ys, marker="o", color=colours[cloud.name], label=cloud.name)
        ax.set_xlabel(BETA_LABEL)
        if log:
            ax.set_yscale("log")
    axes[0].set_ylabel(ylabel)
    _legend(figure, axes)
    return figure


def error_histogram(plan: StudyPlan, result: SweepResult, out: Path) -> Figure:
    """Histogram of per-pair distance errors of one shape at the largest beta, per policy."""
    shape, beta = plan.histogram_shape, plan.histogram_beta
    colour = shape_colours(plan)[shape]
    errors = {}
    for policy in plan.policies:
        spec = result.spec(shape, beta, policy, PLAIN_TECHNIQUE)
        if spec is None:
            continue
        table = read_pairs(out / spec.folder, ["distance_error_pct"])
        values = table.column(0).to_numpy(zero_copy_only=False).astype(np.float64)
        errors[policy] = values[np.isfinite(values)]
    top = max((float(v.max()) for v in errors.values() if len(v)), default=1.0)
    bins = np.linspace(0.0, top, 80).tolist()
    figure, axes = _per_policy_axes(
        plan, f"Distance error of every ordered blind pair with a path: {shape}, β={beta:g}"
    )
    for ax, policy in zip(axes, plan.policies):
        values = errors.get(policy, np.empty(0))
        ax.hist(values, bins=bins, color=colour, label=f"{shape} ({len(values):,} pairs)")
        if len(values):
            mean, p99 = float(values.mean()), float(np.percentile(values, 99))
            ax.axvline(mean, color="black", linestyle="--", label=f"mean {mean:.2f} %")
            ax.axvline(p99, color="grey", linestyle=":", label=f"99th percentile {p99:.2f} %")
        ax.set_yscale("log")
        ax.set_xlabel("distance error (%)")
        ax.legend(loc="upper right")
    axes[0].set_ylabel("ordered blind pairs (log scale)")
    return figure


def box_stats(histogram: Sequence[int], label: str) -> dict[str, Any] | None:
    """Box-plot statistics of integer samples given as counts per value (index = value)."""
    counts = np.asarray(histogram, dtype=np.int64)
    total = int(counts.sum())
    if total == 0:
        return None
    values = np.arange(len(counts))
    cumulative = np.cumsum(counts)

    def quantile(q: float) -> float:
        return float(values[np.searchsorted(cumulative, q * total, side="left")])

    present = values[counts > 0]
    return {
        "label": label,
        "med": quantile(0.5),
        "q1": quantile(0.25),
        "q3": quantile(0.75),
        "whislo": float(present.min()),
        "whishi": float(present.max()),
        "mean": float((values * counts).sum() / total),
        "fliers": [],
    }


def obstructing_boxplot(plan: StudyPlan, result: SweepResult) -> Figure:
    """Distinct obstructing FLSs per obstructed path: boxes per beta, one per shape."""
    colours = shape_colours(plan)
    figure, axes = _per_policy_axes(
        plan,
        "Obstructing FLSs on each obstructed policy-shortest S_all path\n"
        "box: quartiles, line: median, diamond: mean, whiskers: min and max",
    )
    betas = sorted(plan.betas)
    group = len(plan.clouds) + 1
    for ax, policy in zip(axes, plan.policies):
        for index, cloud in enumerate(plan.clouds):
            stats, positions = [], []
            for slot, beta in enumerate(betas):
                summary = result.find(cloud.name, beta, policy, PLAIN_TECHNIQUE)
                box = (
                    None
                    if summary is None
                    else box_stats(summary.pairs.obstructing_flss_histogram, f"{beta:g}")
                )
                if box is not None:
                    stats.append(box)
                    positions.append(slot * group + index)
            if not stats:
                continue
            artists = ax.bxp(
                stats,
                positions=positions,
                widths=0.8,
                patch_artist=True,
                showmeans=True,
                meanprops={"marker": "D", "markerfacecolor": "white", "markersize": 3},
                medianprops={"color": "black"},
            )
            for patch in artists["boxes"]:
                patch.set_facecolor(colours[cloud.name])
            artists["boxes"][0].set_label(cloud.name)
        ax.set_xticks([slot * group + (group - 2) / 2 for slot in range(len(betas))])
        ax.set_xticklabels([f"{beta:g}" for beta in betas])
        ax.set_xlabel(BETA_LABEL)
    axes[0].set_ylabel("obstructing FLSs per path")
    _legend(figure, axes)
    return figure


def error_by_hops(plan: StudyPlan, result: SweepResult, out: Path) -> Figure | None:
    """Mean and 95th-percentile distance error by the policy path's hops: path sums, fit.

    One shape (that of the histogram) at the largest beta; None when the
    study has no least-squares runs. A path's estimate gathers an error per
    hop; the fit's does not grow with the path the policy would take.
    """
    fitted = [estimator for estimator in plan.estimators if estimator.name == FIT]
    if not fitted:
        return None
    shape = plan.histogram_shape
    beta = max(plan.betas)
    policy = plan.heuristic_policy
    columns: dict[str, Any] = {}
    for label, technique in (("path", PLAIN_TECHNIQUE), ("fit", fitted[0])):
        spec = result.spec(shape, beta, policy, technique)
        if spec is None:
            return None
        table = read_pairs(out / spec.folder, ["distance_error_pct", "path"])
        columns[label] = table.column("distance_error_pct").to_numpy(zero_copy_only=False)
        if label == "path":
            paths = table.column("path").to_pylist()
            columns["hops"] = np.array([max(len(path) - 1, 0) for path in paths])
    hops = columns["hops"]
    figure = Figure(figsize=(8.5, 4.8), layout="constrained")
    ax = figure.subplots()
    title = POLICY_TITLES.get(policy, policy)
    figure.suptitle(f"Distance error by the {title} path's hops: {shape}, β={beta:g}")
    counts = np.bincount(hops)
    steps = [h for h in range(1, len(counts)) if counts[h] > 0]
    for label, name, colour in (
        ("path", f"{title}: the path's measured hops summed", "tab:blue"),
        ("fit", "least-squares fit over every measurement", "tab:orange"),
    ):
        values = np.asarray(columns[label], dtype=np.float64)
        means = [float(np.nanmean(values[hops == h])) for h in steps]
        p95 = [float(np.nanpercentile(values[hops == h], 95)) for h in steps]
        ax.plot(steps, means, "-o", color=colour, label=f"{name}: mean")
        ax.plot(steps, p95, ":x", color=colour, label=f"{name}: 95th percentile")
    ax.set_yscale("log")
    ax.set_xlabel("hops of the policy's path (pairs)")
    ax.set_ylabel("distance error (%, log scale)")
    ax.set_xticks(steps, [f"{h}\n({counts[h]:,})" for h in steps])
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return figure


def study_figures(plan: StudyPlan, result: SweepResult, out: Path) -> dict[str, Path]:
    """Draw and write every figure of the study into ``out/figures``; return name -> path."""
    folder = out / "figures"

    def stat(key: str, name: str) -> Callable[[Summary], float | None]:
        return lambda summary: getattr(getattr(summary.pairs, key), name)

    figures = {
        "distance_error_mean": metric_vs_beta(
            plan,
            result,
            stat("distance_error_pct", "mean"),
            "Mean distance error of plain Swazure",
            "mean distance error (%)",
            fused=True,
        ),
        "distance_error_max": metric_vs_beta(
            plan,
            result,
            stat("distance_error_pct", "max"),
            "Maximum distance error of plain Swazure",
            "max distance error (%, log scale)",
            log=True,
            fused=True,
        ),
        "alpha_mean": metric_vs_beta(
            plan,
            result,
            stat("alpha_deg", "mean"),
            "Mean angle α between estimated and true relative vector",
            "mean α (degrees)",
            fused=True,
        ),
        "obstructed_paths": metric_vs_beta(
            plan,
            result,
            lambda summary: summary.pairs.obstructed_path_pct,
            "Pairs whose policy-shortest sweet path has an obstructed hop",
            "obstructed sweet paths (% of pairs with an S_all path)",
        ),
        "obstructing_flss": obstructing_boxplot(plan, result),
        "distance_error_histogram": error_histogram(plan, result, out),
    }
    by_hops = error_by_hops(plan, result, out)
    if by_hops is not None:
        figures["distance_error_by_hops"] = by_hops
    return {name: save(figure, folder / f"{name}.png") for name, figure in figures.items()}


#: Estimator of a track -> (label, line style) in :func:`track_figure`.
TRACK_LINES = {
    "raw": ("central differences (received)", {"linestyle": "none", "marker": ".", "ms": 3}),
    "filtered": ("Kalman, at the sample time", {"linestyle": ":", "lw": 1.2}),
    "predicted": ("Kalman, predicted to now", {"linestyle": "-", "lw": 1.4}),
}


def track_figure(series: Any, title: str, path: Path) -> Path:
    """True and estimated relative velocity and acceleration per axis over time, as PNG.

    ``series`` is a :class:`~swazure_ros.core.tracking.TrackSeries`.
    """
    figure = Figure(figsize=(13.0, 6.5), layout="constrained")
    axes = figure.subplots(2, 3, sharex=True)
    figure.suptitle(title)
    for row, (quantity, unit, truth, estimates) in enumerate(
        (
            ("velocity", "cm/s", series.truth_velocity, series.velocity),
            ("acceleration", "cm/s²", series.truth_acceleration, series.acceleration),
        )
    ):
        for column, axis_name in enumerate("xyz"):
            ax = axes[row][column]
            ax.plot(series.time, truth[:, column], color="black", lw=2.2, alpha=0.35, label="true")
            for estimator, (label, style) in TRACK_LINES.items():
                ax.plot(series.time, estimates[estimator][:, column], label=label, **style)
            ax.set_title(f"{quantity} {axis_name}")
            ax.set_ylabel(unit)
            ax.grid(True, alpha=0.3)
            if row == 1:
                ax.set_xlabel("time, s (simulated)")
    handles, labels = axes[0][0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="outside lower center", ncols=4)
    return save(figure, path)


def study_snapshots(plan: StudyPlan, out: Path) -> dict[str, Path]:
    """One snapshot per shape of the study, at its beta nearest 0.5: out/figures/snapshot_*.png.

    The study's runs keep summaries, not swarms: each shape is evaluated once
    more here (the plan's heuristic policy, plain Swazure). A snapshot is
    drawn again only when its run's cache key changed (kept beside it as
    ``snapshot_*.key``), so a study with nothing to compute draws none.
    """
    beta = min(plan.betas, key=lambda candidate: (abs(candidate - 0.5), candidate))
    keys = {
        spec.cloud: spec.key
        for spec in plan.runs()
        if spec.beta == beta
        and spec.policy == plan.heuristic_policy
        and spec.technique == PLAIN_TECHNIQUE
    }
    written = {}
    for cloud in plan.clouds:
        name = f"snapshot_{cloud.name}"
        path = out / "figures" / f"{name}.png"
        key_path = path.with_suffix(".key")
        key = keys.get(cloud.name, "")
        if key and path.is_file() and _read(key_path) == key:
            written[name] = path
            continue
        swarm = make_swarm(cloud.points, beta=beta, seed=plan.seed)
        evaluation = evaluate(swarm, plan.sensor, plan.heuristic_policy)
        title = (
            f"{cloud.name}, beta {beta:g}, {plan.heuristic_policy}: each FLS's share of blind "
            "neighbours with a sweet path"
        )
        written[name] = write_snapshot(evaluation_scene(evaluation, title), path)
        atomic_write(key_path, partial(Path.write_text, data=key))
    return written


def _read(path: Path) -> str | None:
    """The text of ``path``; None when it cannot be read."""
    try:
        return read_text(path, "key", CONFIG_BYTES, SwazureError)
    except SwazureError:
        return None
