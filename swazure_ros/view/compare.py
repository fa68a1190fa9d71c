"""The error distributions of compared runs (``swazure compare``) as one PNG.

One panel per class of pairs that a run has pairs of (all pairs first), one
curve per run: the share of the class's pairs whose error is at most x. A
curve ends at the run's coverage, so a run that estimates fewer of the
class's pairs ends lower, and a curve further left has smaller errors.
Built on ``matplotlib.figure.Figure`` (the Agg canvas, no pyplot state).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..core.compare import Comparison, cloud_of
from ..core.pair_classes import CDF_LEVELS, PAIR_CLASSES
from .png import save

#: One panel's size, inches; the legend below the panels takes LEGEND_HEIGHT per row.
PANEL_WIDTH, PANEL_HEIGHT, LEGEND_HEIGHT = 4.6, 4.2, 0.3
#: Runs in one row of the legend.
LEGEND_COLUMNS = 3
#: Dash patterns by run, so that runs whose curves lie on each other (a fit solved two
#: ways) stay visible.
DASHES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)))
#: The first run's line width, points, and how much narrower each next run's is.
WIDEST, WIDTH_STEP = 2.8, 0.4
#: A log axis when the errors span at least this factor (decaying hops beside sweet ones).
LOG_SPAN = 50.0
#: Errors at or below this, in the comparison's unit, sit at the log axis's left edge.
SMALLEST = 1e-6


def panels(comparison: Comparison) -> list[int]:
    """The classes (indices of PAIR_CLASSES) drawn: those some run has a pair of."""
    return [
        code
        for code in range(len(PAIR_CLASSES))
        if any(run.classes is not None and run.classes[code].pairs for run in comparison.runs)
    ]


def grid(count: int) -> tuple[int, int]:
    """Rows and columns of ``count`` panels: one row up to three, then two or three across
    (four panels two by two, not four squat ones in a row)."""
    columns = count if count <= 3 else 2 if count == 4 else 3
    return -(-max(count, 1) // max(columns, 1)), max(columns, 1)


def figure_size(comparison: Comparison) -> tuple[float, float]:
    """The figure's size in inches: its grid of panels, and the legend's rows below."""
    rows, columns = grid(len(panels(comparison)))
    legend_rows = -(-len(comparison.runs) // LEGEND_COLUMNS)
    return PANEL_WIDTH * columns, PANEL_HEIGHT * rows + LEGEND_HEIGHT * legend_rows


def error_figure(comparison: Comparison, title: str = "") -> Figure:
    """The runs' error distributions by class of pairs, one panel per class."""
    codes = panels(comparison)
    figure = Figure(figsize=figure_size(comparison), layout="constrained")
    rows, columns = grid(len(codes))
    axes = figure.subplots(rows, columns, sharey=True, squeeze=False).ravel()
    for spare in axes[len(codes) :]:
        spare.set_visible(False)
    unit = comparison.error_unit
    name = "position error (cm)" if unit == "cm" else "distance error (%)"
    cloud = cloud_of(comparison.runs[0].summary)
    figure.suptitle(title or f"{cloud}: {name} by class of pairs")
    quantiles = [
        value
        for run in comparison.runs
        for result in run.classes or ()
        for value in result.cdf
        if value > SMALLEST
    ]
    span = max(quantiles) / min(quantiles) if quantiles else 1.0
    for ax, code in zip(axes, codes, strict=False):
        pairs = max(run.classes[code].pairs for run in comparison.runs if run.classes)
        ax.set_title(f"{PAIR_CLASSES[code]} ({pairs:,} pairs)")
        for index, run in enumerate(comparison.runs):
            if run.classes is None:
                continue
            result = run.classes[code]
            if not result.cdf:
                continue  # none of the class's pairs estimated: its coverage says so
            x = np.maximum(np.asarray(result.cdf), SMALLEST) if result.cdf else np.zeros(0)
            share = (result.coverage_pct or 0.0) * CDF_LEVELS[: len(x)]
            ax.plot(
                x,
                share,
                linestyle=DASHES[index % len(DASHES)],
                color=f"C{index % 10}",
                # Earlier runs wider: a later run's curve on top of one leaves it visible.
                linewidth=max(WIDEST - WIDTH_STEP * index, 1.0),
                label=run.label if run.label == run.method else f"{run.label}: {run.method}",
            )
        missing = [
            run.label for run in comparison.runs if run.classes and not run.classes[code].cdf
        ]
        if ax.lines and missing:
            # A run with no curve here estimates none of these pairs: say so, not only hide it.
            note = "none estimated:\n" + "\n".join(missing)
            ax.text(0.97, 0.03, note, ha="right", va="bottom", transform=ax.transAxes)
        if not ax.lines:
            ax.text(0.5, 0.5, "no run estimates any", ha="center", transform=ax.transAxes)
            ax.set_xticks([])
        elif span >= LOG_SPAN:
            ax.set_xscale("log")
        ax.set_xlabel(name + (", log scale" if span >= LOG_SPAN else ""))
        ax.set_ylim(0, 102)
        ax.grid(True, which="major", alpha=0.3)
    for row in range(rows):
        axes[row * columns].set_ylabel("pairs with at most this error, % of the class")
    handles, labels = [], []
    for ax in axes:  # every run once, from the panels it is drawn in
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            if label not in labels:
                handles.append(handle)
                labels.append(label)
    if handles:
        figure.legend(handles, labels, loc="outside lower center", ncols=LEGEND_COLUMNS)
    return figure


def write_error_figure(comparison: Comparison, path: Path, title: str = "") -> Path:
    """Draw :func:`error_figure` and write it to ``path`` as PNG, atomically."""
    return save(error_figure(comparison, title), path)
