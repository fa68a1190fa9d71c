"""Compare runs side by side: summaries, differences, error distributions, who did better where.

Each RUN is an output folder of swazure evaluate --out or swazure spawn --out
(summary.json, and pairs.csv or pairs.parquet), all of one cloud. Prints the
runs' summary rows side by side, their results by class of pairs, and which
run did better on each class; writes comparison.csv, comparison.json and
errors.png (the error distributions) into --output.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..core.compare import Comparison
from ..core.metric_rows import MetricRow
from ..files.runs import compare_runs, write_comparison
from ..view.compare import write_error_figure
from .arguments import output_folder

#: The figure's file in the output folder.
FIGURE_FILE = "errors.png"
#: The output folder when --output is not given: beside the first run.
DEFAULT_OUTPUT = "comparison"

COMPARE_TERMS = """\
what it prints:
  runs             each run's label (its folder's name), what it ran (plain, a
                   heuristic, fused paths or an estimator), beta, policy, sensor
  the table        one column per run; the rows are the numbers of the runs'
                   summaries (swazure evaluate --help explains each); "-": the run
                   has no such number, and the lines "-, why:" below the table say
                   why (a heuristic's moves in a fit's run, a fit's predicted error
                   or NEES without a noise model, a statistic of no pairs)
  *, better (by)   where a row has a better direction (lower: errors, moves,
                   seconds, no path; higher: sweet path, resolved pairs, coverage),
                   * marks the best run and "better" names it, with how far it is
                   ahead of the next run (its value minus the next one's); values
                   within 1e-4 of each other (relative) tie; comparison.csv has
                   every run's difference from the first run
  by class         the pairs by their reason in pairs.csv, which no heuristic and
                   no estimator changes, so every run is judged on the same pairs:
                   sweet path (a sweet path in sight), blocked (every sweet path
                   obstructed by an FLS: a decaying path or none; the pairs a
                   heuristic tries), no sweet path (the sweet graph does not join
                   them), aborted (a distributed run's coordinator left)
  coverage, %      the share of the class's pairs that the run estimates
  median / mean error
                   of the pairs the run estimates: the position error
                   |estimate - truth| in cm (the distance error in % when a
                   per-pair file has no truth columns)
  better, by class which run did better on each class: by median error (robust
                   to a few decaying hops' large errors; the mean is in the table)
                   and by coverage, the runs ranked best first, "=" for a tie
  errors.png       per class, the share of its pairs with at most each error, one
                   curve per run: further left is more accurate, and a curve ends
                   at the run's coverage

runs of different clouds are refused (exit 2): their pairs are not the same
pairs. Runs of one cloud with another beta, sensor, policy or seed compare, their
parameters shown; a class's pairs then differ in number, which the verdict says.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure compare``."""
    parser.epilog = COMPARE_TERMS
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument(
        "runs",
        nargs="+",
        type=Path,
        metavar="RUN",
        help="a run's output folder (swazure evaluate --out, swazure spawn --out); two or "
        "more, the first the reference of the differences",
    )
    parser.add_argument(
        "--output",
        type=output_folder,
        default=None,
        metavar="DIR",
        help=f"write comparison.csv, comparison.json and {FIGURE_FILE} here (default: a "
        f"folder '{DEFAULT_OUTPUT}' beside the first RUN, replaced by the next comparison)",
    )


def _figure(value: float | None) -> str:
    if value is None:
        return "-"
    if value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return f"{value:.4g}"


def _better(row: MetricRow, labels: list[str]) -> str:
    if not row.best or row.margin is None:
        return ""
    margin = row.margin
    by = f"{margin:+.0f}" if abs(margin) >= 1000 else f"{margin:+.3g}"
    return f"{' = '.join(labels[i] for i in row.best)} (by {by})"


def comparison_table(comparison: Comparison) -> str:
    """The runs' rows side by side: a column per run (* on the best), then the better run."""
    labels = [run.label for run in comparison.runs]
    rows = [*comparison.rows, None, *comparison.class_rows]
    cells = [
        [_figure(value) + ("*" if i in row.best else "") for i, value in enumerate(row.values)]
        for row in rows
        if row is not None
    ]
    width = max(len(text) for text in [*labels, *(c for line in cells for c in line)]) + 2
    left = max(len(row.label) for row in rows if row is not None) + 2
    lines = [f"{'':<{left}}" + "".join(f"{label:>{width}}" for label in labels) + "  better (by)"]
    found = iter(cells)
    for row in rows:
        if row is None:
            lines.append(f"by class of pairs, error in {comparison.error_unit}:")
            continue
        values = "".join(f"{text:>{width}}" for text in next(found))
        lines.append(f"{row.label:<{left}}{values}  {_better(row, labels)}".rstrip())
    return "\n".join(lines)


def absent_text(comparison: Comparison) -> str:
    """Why a run shows "-": one line per reason and its runs, naming the rows."""
    labels = [run.label for run in comparison.runs]
    rows_by_why: dict[tuple[str, tuple[str, ...]], list[str]] = {}
    for row in (*comparison.rows, *comparison.class_rows):
        runs_by_why: dict[str, list[str]] = {}
        for label, why in zip(labels, row.why_none, strict=True):
            if why is not None:
                runs_by_why.setdefault(why, []).append(label)
        for why, runs in runs_by_why.items():
            rows_by_why.setdefault((why, tuple(runs)), []).append(row.label)
    lines = [
        f"  {', '.join(runs)}: {why} ({'; '.join(rows)})"
        for (why, runs), rows in rows_by_why.items()
    ]
    return "\n".join(["-, why:", *lines]) if lines else ""


def _runs_text(comparison: Comparison) -> str:
    lines = []
    width = max(len(run.label) for run in comparison.runs) + 2
    for run in comparison.runs:
        asked = run.summary.parameters
        beta = "-" if asked.beta is None else f"{asked.beta:g}"
        sensor = asked.sensor.get("name", "-")
        lines.append(
            f"  {run.label:<{width}}{run.method}, beta {beta}, {asked.policy}, sensor {sensor}"
        )
    return "\n".join(lines)


def default_output(first: Path) -> Path:
    """The folder ``comparison`` beside the first run (beside it, never inside it: a run
    named ``.`` or ``..`` is resolved first)."""
    if first.name in ("", ".", ".."):
        first = first.resolve()
    return first.parent / DEFAULT_OUTPUT


def main(args: argparse.Namespace) -> int:
    """Run ``swazure compare``."""
    comparison = compare_runs(args.runs)
    output = args.output or default_output(args.runs[0])
    source = comparison.runs[0].summary.parameters.source
    cloud = source.cloud if source is not None else "one cloud"
    print(f"runs of {cloud}:")
    print(_runs_text(comparison))
    print(comparison_table(comparison))
    absent = absent_text(comparison)
    if absent:
        print(absent)
    skipped = [run.label for run in comparison.runs if run.classes is None]
    if skipped:
        print(f"no per-pair file, so not by class or in the figure: {', '.join(skipped)}")
    if comparison.verdicts:
        print("better, by class of pairs (median error of the pairs estimated; coverage):")
        for verdict in comparison.verdicts:
            print(f"  {verdict.statement}")
    json_path, csv_path = write_comparison(output, comparison)
    if len(skipped) == len(comparison.runs):
        print(f"wrote {csv_path} and {json_path} (no figure: no run has a per-pair file)")
        return 0
    figure = write_error_figure(comparison, output / FIGURE_FILE)
    print(f"wrote {csv_path}, {json_path} and {figure}")
    return 0
