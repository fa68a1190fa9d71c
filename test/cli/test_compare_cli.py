"""``swazure compare`` in a real process, on real runs of ``swazure evaluate``.

Three runs of one small built-in shape (no ../shared needed) with blocked
pairs that Move Obstructing resolves: plain, Move Obstructing, least-squares.
The numbers the comparison prints are checked against the runs' own
summary.json, and its verdicts against errors computed here from pairs.csv.
"""

import csv
import json
import struct
from pathlib import Path

import numpy as np
import pytest

from swazure_ros.view.compare import (
    LEGEND_COLUMNS,
    LEGEND_HEIGHT,
    PANEL_HEIGHT,
    PANEL_WIDTH,
    grid,
)
from swazure_ros.view.png import DPI

from .test_evaluate_cli import swazure  # one home for running swazure in a process

SHAPE = ["--cloud", "torus:200", "--beta", "0.5", "--quiet"]
RUNS = {
    "plain": [],
    "move-obstructing": ["--technique", "move-obstructing"],
    "least-squares": ["--estimator", "least-squares"],
}
CLASS_OF_REASON = {"": "sweet path", "BLOCKED": "blocked", "NO_SWEET_PATH": "no sweet path"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The three runs' folders, and the comparison of them: its printed text and folder."""
    root = tmp_path_factory.mktemp("runs")
    for name, options in RUNS.items():
        run = swazure("evaluate", *SHAPE, *options, "--out", str(root / name))
        assert run.returncode == 0, run.stderr
    compared = swazure("compare", *RUNS, cwd=root)
    return root, compared


def pair_errors(folder: Path) -> dict[str, np.ndarray]:
    """Each class's position errors, cm, computed here from pairs.csv (NaN: no estimate)."""
    by_class: dict[str, list[float]] = {}
    with (folder / "pairs.csv").open(newline="") as file:
        for row in csv.DictReader(file):
            estimate = np.array([float(row[f"estimate_{axis}"]) for axis in "xyz"])
            truth = np.array([float(row[f"truth_{axis}"]) for axis in "xyz"])
            error = float(np.linalg.norm(estimate - truth))
            by_class.setdefault(CLASS_OF_REASON[row["reason"]], []).append(error)
    return {name: np.array(errors) for name, errors in by_class.items()}


def table_row(text: str, label: str) -> list[str]:
    line = next(line for line in text.splitlines() if line.startswith(label + " "))
    return line[len(label) :].split()


def test_the_table_names_every_run_and_shows_each_summarys_numbers(runs):
    root, compared = runs
    assert compared.returncode == 0, compared.stderr
    assert compared.stderr == ""
    header = next(line for line in compared.stdout.splitlines() if "better (by)" in line)
    assert header.split()[:3] == list(RUNS)
    summaries = [json.loads((root / name / "summary.json").read_text()) for name in RUNS]
    sweet = table_row(compared.stdout, "sweet path, %")
    assert [value.rstrip("*") for value in sweet[:3]] == [
        f"{s['sweet_pct']:.4g}" for s in summaries
    ]
    # Move Obstructing resolves blocked pairs: the most sweet paths, marked and named.
    assert sweet[1].endswith("*") and sweet[3] == "move-obstructing"
    resolved = table_row(compared.stdout, "resolved pairs")
    # A number only one run has is shown, not judged: there is nothing to be better than.
    assert resolved == ["-", str(summaries[1]["resolved_pairs"]), "-"]
    mean = table_row(compared.stdout, "distance error, %: mean")
    assert [v.rstrip("*") for v in mean[:3]] == [
        f"{s['distance_error_pct']['mean']:.4g}" for s in summaries
    ]


def ranking(text: str, unit: str) -> dict[str, str]:
    """``a 0.1 = b 0.1 < c 0.3 cm`` as {run: value as printed}, in the order given."""
    ranked = text.split(f" {unit}")[0]
    if ranked.startswith("all "):
        return {name: ranked.split()[1] for name in RUNS}
    parts = ranked.replace(" = ", " < ").replace(" > ", " < ").split(" < ")
    return dict(part.rsplit(" ", 1) for part in parts)


def test_the_verdicts_match_the_errors_of_the_pairs(runs):
    root, compared = runs
    errors = [pair_errors(root / name) for name in RUNS]
    verdicts = {
        line.strip().split(" (")[0]: line.strip()
        for line in compared.stdout.split("better, by class of pairs")[1].splitlines()[1:]
        if line.startswith("  ")
    }
    assert set(verdicts) == {"all pairs", *errors[0]}
    for pair_class in errors[0]:
        found = [e[pair_class][np.isfinite(e[pair_class])] for e in errors]
        coverage = {
            name: 100.0 * len(f) / len(e[pair_class]) for name, f, e in zip(RUNS, found, errors)
        }
        medians = {name: float(np.median(f)) for name, f in zip(RUNS, found) if len(f)}
        statement = verdicts[pair_class]
        assert statement.startswith(f"{pair_class} ({len(errors[0][pair_class]):,} pairs): ")
        # Every run ranked by coverage, best first, with its value.
        by_coverage = ranking(statement.split("; by coverage ")[1], "%")
        assert by_coverage == {name: f"{coverage[name]:.4g}" for name in by_coverage}
        assert set(by_coverage) == set(RUNS)
        order = [coverage[name] for name in by_coverage]
        assert order == sorted(order, reverse=True), statement
        if not medians:
            assert "no run estimates any" in statement
            continue
        # The runs that estimate any ranked by median error, smallest first.
        by_median = ranking(statement.split("by median error ")[1], "cm")
        assert by_median == {name: f"{medians[name]:.4g}" for name in medians}
        order = [medians[name] for name in by_median]
        assert order == pytest.approx(sorted(order), rel=1e-4), statement
    # The blocked pairs: Move Obstructing estimates most of them, plain and the fit none.
    blocked = verdicts["blocked"]
    assert "; by coverage move-obstructing " in blocked
    assert "(plain, least-squares: none estimated)" in blocked


def test_the_figure_and_the_files_are_written_beside_the_runs(runs):
    root, compared = runs
    output = root / "comparison"  # the default: beside the first run
    figure = output / "errors.png"
    head = figure.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR"
    width, height = struct.unpack(">II", head[16:24])
    # A panel for all pairs, then one per class present: four, two by two; a legend row.
    rows, columns = grid(1 + len(pair_errors(root / "plain")))
    assert (rows, columns) == (2, 2)
    legend_rows = -(-len(RUNS) // LEGEND_COLUMNS)
    assert (width, height) == (
        round(PANEL_WIDTH * columns * DPI),
        round((PANEL_HEIGHT * rows + LEGEND_HEIGHT * legend_rows) * DPI),
    )
    document = json.loads((output / "comparison.json").read_text())
    assert [run["label"] for run in document["runs"]] == list(RUNS)
    statements = [v["statement"] for v in document["verdicts"]]
    assert all(f"  {statement}" in compared.stdout for statement in statements)
    table = list(csv.DictReader((output / "comparison.csv").read_text().splitlines()))
    sweet = next(row for row in table if row["row"] == "sweet path, %")
    assert float(sweet["delta move-obstructing"]) == pytest.approx(
        float(sweet["move-obstructing"]) - float(sweet["plain"])
    )
    written = [output / name for name in ("comparison.csv", "comparison.json", "errors.png")]
    relative = [str(path.relative_to(root)) for path in written]
    assert compared.stdout.endswith(f"wrote {relative[0]}, {relative[1]} and {relative[2]}\n")


def test_runs_of_two_clouds_are_refused_in_one_line(runs, tmp_path):
    root, _ = runs
    other = swazure(
        "evaluate", "--cloud", "helix:60", "--beta", "0.5", "--out", "helix", cwd=tmp_path
    )
    assert other.returncode == 0, other.stderr
    refused = swazure("compare", str(root / "plain"), "helix", cwd=tmp_path)
    assert refused.returncode == 2
    assert refused.stderr == (
        "swazure compare: error: runs of different clouds: plain (torus_200), helix (helix_60); "
        "compare runs of one cloud\n"
    )
    assert not (tmp_path / "comparison").exists() and not (root / "comparison.json").exists()


def test_help_says_what_each_part_means():
    text = swazure("compare", "--help").stdout
    for term in ("better (by)", "coverage, %", "median / mean error", "errors.png", "--output"):
        assert term in text


def test_the_docs_page_holds_the_help_text():
    from swazure_ros.cli.compare import COMPARE_TERMS

    page = (Path(__file__).resolve().parents[2] / "docs" / "compare.md").read_text()
    assert COMPARE_TERMS.rstrip("\n") in page


def test_a_run_without_a_number_shows_a_dash_and_the_lines_below_say_why(runs):
    """Issue 69: a row shows "-" only with its reason, in a comparison as in a summary."""
    _, compared = runs
    lines = compared.stdout.splitlines()
    table = lines[lines.index(next(line for line in lines if "better (by)" in line)) :]
    table = table[: table.index("-, why:")]
    dashed = set()
    for line in table[1:]:
        if line.startswith("by class"):
            continue
        label = line.split("  ")[0]
        cells = table_row(compared.stdout, label)[: len(RUNS)]
        dashed |= {(label, run) for run, cell in zip(RUNS, cells, strict=True) if cell == "-"}
    assert dashed, "the plain and least-squares runs have no heuristic's moves"
    why = lines[lines.index("-, why:") + 1 :]
    why = why[: next(i for i, line in enumerate(why) if not line.startswith("  "))]
    explained = set()
    for line in why:
        runs_text, _, rest = line.strip().partition(": ")
        reason, _, rows = rest.rpartition(" (")
        assert reason, line
        for label in rows.removesuffix(")").split("; "):
            explained |= {(label, run) for run in runs_text.split(", ")}
    assert dashed == explained
    assert (
        "  plain, least-squares: no heuristic in this run "
        "(tried pairs; resolved pairs; moved per resolved pair, cm: mean)"
    ) in why
