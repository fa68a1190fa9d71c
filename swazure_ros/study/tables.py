"""The study's tables (spec, section 10), built from the runs' summaries.

Each table has a CSV form with full-precision values, one column per number,
and a Markdown form for people, where numbers are rounded and mean and max
share a cell. Cells of runs that the study did not make are empty (CSV) or
``-`` (Markdown).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

from ..core.errors import SwazureError
from ..core.heuristics.result import MOVE_SOURCE
from ..core.metrics import Stats
from ..core.summary import HeuristicFacts, Summary
from .plan import PLAIN_TECHNIQUE, StudyPlan, Technique
from .sweep import SweepResult

#: The betas of the published no-path and decaying-path columns (spec, section 10).
NO_PATH_BETAS = (0.4, 0.5)
DECAYING_BETAS = (0.3, 0.4, 0.5)


@dataclass
class Table:
    """A table in two forms: full-precision CSV and rounded Markdown."""

    name: str  # file stem, e.g. ``paths_plain``
    title: str
    columns: list[str]
    rows: list[list[Any]]
    display_columns: list[str]
    display_rows: list[list[str]]
    note: str = ""

    def to_csv(self) -> str:
        """The CSV text: a header line, then one line per row."""
        buffer = io.StringIO()
        writer = csv.writer(buffer, lineterminator="\n")
        writer.writerow(self.columns)
        writer.writerows([["" if value is None else value for value in row] for row in self.rows])
        return buffer.getvalue()

    def to_markdown(self) -> str:
        """The Markdown text: title, table, note."""
        lines = [f"### {self.title}", ""]
        lines.append("| " + " | ".join(self.display_columns) + " |")
        lines.append("| " + " | ".join(["---"] * len(self.display_columns)) + " |")
        lines += ["| " + " | ".join(row) + " |" for row in self.display_rows]
        if self.note:
            lines += ["", self.note]
        return "\n".join(lines) + "\n"


def _fmt(value: Any, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _of(stats: Stats | None, name: str) -> float | int | None:
    """Statistic ``name`` (mean, max, count) of ``stats``; None (an empty cell) without any."""
    return None if stats is None else getattr(stats, name)


def _facts(summary: Summary) -> HeuristicFacts:
    """A heuristic run's facts: tried, resolved, moved."""
    if summary.heuristic is None:
        raise SwazureError(
            f"{summary.study and summary.study.run}: a heuristic's run without facts"
        )
    return summary.heuristic


def _table_betas(wanted: Sequence[float], available: Sequence[float]) -> list[float]:
    """The published betas the study has, or all it has when none of them."""
    chosen = [beta for beta in wanted if beta in available]
    return chosen or sorted(available)


def paths_table(plan: StudyPlan, result: SweepResult, technique: Technique) -> Table:
    """% of ordered blind pairs with no path and with a decaying path, per shape."""
    no_path_betas = _table_betas(NO_PATH_BETAS, plan.heuristic_betas)
    decaying_betas = _table_betas(DECAYING_BETAS, plan.heuristic_betas)
    policy = plan.heuristic_policy
    columns = ["shape", "flss"]
    columns += [f"no_path_pct_beta_{beta:g}" for beta in no_path_betas]
    columns += [f"decaying_pct_beta_{beta:g}" for beta in decaying_betas]
    display = ["shape", "FLSs"]
    display += [f"no path, β={beta:g}" for beta in no_path_betas]
    display += [f"decaying, β={beta:g}" for beta in decaying_betas]
    rows, display_rows = [], []
    for cloud in plan.clouds:
        row: list[Any] = [cloud.name, len(cloud.points)]
        for key, betas in (("no_path_pct", no_path_betas), ("decaying_pct", decaying_betas)):
            for beta in betas:
                summary = result.find(cloud.name, beta, policy, technique)
                row.append(None if summary is None else getattr(summary.pairs, key))
        rows.append(row)
        display_rows.append([cloud.name, str(len(cloud.points))] + [_fmt(v) for v in row[2:]])
    return Table(
        f"paths_{technique.label}",
        f"Blind pairs with no path and with a decaying path (%): {technique.title}",
        columns,
        rows,
        display,
        display_rows,
        f"Policy {policy}; % of ordered blind pairs.",
    )


def moved_table(plan: StudyPlan, result: SweepResult) -> Table:
    """Mean and max distance moved by FLSs at the largest heuristic beta, per technique."""
    beta = max(plan.heuristic_betas)
    policy = plan.heuristic_policy
    columns, display = ["shape", "flss"], ["shape", "FLSs"]
    for technique in plan.techniques:
        columns += [f"{technique.label}_{stat}" for stat in ("tried", "resolved", "moves")]
        columns += [f"{technique.label}_moved_mean_cm", f"{technique.label}_moved_max_cm"]
        columns += [
            f"{technique.label}_per_pair_mean_cm",
            f"{technique.label}_per_pair_max_cm",
            f"{technique.label}_failed_moves",
            f"{technique.label}_failed_moved_mean_cm",
        ]
        display.append(f"{technique.title}: moved, cm")
        display.append(f"{technique.title}: per resolved pair, cm")
        if technique.name == MOVE_SOURCE:
            columns += [f"{technique.label}_flown_mean_cm", f"{technique.label}_flown_max_cm"]
            display.append(f"{technique.title}: flown, cm")
    rows, display_rows = [], []
    for cloud in plan.clouds:
        row: list[Any] = [cloud.name, len(cloud.points)]
        cells = [cloud.name, str(len(cloud.points))]
        for technique in plan.techniques:
            summary = result.find(cloud.name, beta, policy, technique)
            facts = None if summary is None else _facts(summary)
            moved = None if facts is None else facts.moved_distance
            per_pair = None if facts is None else facts.moved_per_resolved_pair
            failed = None if facts is None else facts.failed_moved_distance
            flown = None if facts is None else facts.flown_distance
            tried, resolved = (
                (None, None) if facts is None else (facts.tried_pairs, facts.resolved_pairs)
            )
            row += [tried, resolved, _of(moved, "count"), _of(moved, "mean"), _of(moved, "max")]
            row += [_of(per_pair, "mean"), _of(per_pair, "max")]
            row += [_of(failed, "count"), _of(failed, "mean")]
            cells.append(f"{_fmt(_of(moved, 'mean'), 3)} ({_fmt(_of(moved, 'max'), 3)})")
            cells.append(f"{_fmt(_of(per_pair, 'mean'), 3)} ({_fmt(_of(per_pair, 'max'), 3)})")
            if technique.name == MOVE_SOURCE:
                row += [_of(flown, "mean"), _of(flown, "max")]
                cells.append(f"{_fmt(_of(flown, 'mean'), 3)} ({_fmt(_of(flown, 'max'), 3)})")
        rows.append(row)
        display_rows.append(cells)
    return Table(
        f"moved_beta_{beta:g}",
        f"Distance moved by FLSs at β={beta:g}, mean (max), cm",
        columns,
        rows,
        display,
        display_rows,
        f"Policy {policy}. Moved: per move, of the resolved pairs only (the moves of pairs "
        "that still failed are the failed_moves columns of the CSV). Move Obstructing: every "
        "individual move of an obstructing FLS. Move Source: the source's net displacement, "
        "and the distance it flew probing. Per resolved pair: what a resolved pair's FLSs "
        "moved in all, the published Table 3's metric.",
    )


def errors_table(plan: StudyPlan, result: SweepResult) -> Table:
    """Plain Swazure per shape, beta and policy: paths, errors and obstruction (figure data)."""
    columns = [
        "shape",
        "beta",
        "policy",
        "blind_pairs",
        "sweet_pct",
        "decaying_pct",
        "no_path_pct",
        "distance_error_mean_pct",
        "distance_error_max_pct",
        "alpha_mean_deg",
        "alpha_max_deg",
        "obstructed_path_pct",
        "obstructing_flss_mean",
    ]
    display = [
        "shape",
        "β",
        "policy",
        "blind pairs",
        "sweet %",
        "decaying %",
        "no path %",
        "distance error % mean (max)",
        "α° mean (max)",
        "obstructed %",
    ]
    rows, display_rows = [], []
    variants = [(policy, policy, PLAIN_TECHNIQUE) for policy in plan.policies]
    for estimator in plan.estimators:
        label = f"{plan.heuristic_policy}, {estimator.label}"
        variants.append((label, plan.heuristic_policy, estimator))
    for cloud in plan.clouds:
        for label, policy, technique in variants:
            for beta in plan.betas:
                summary = result.find(cloud.name, beta, policy, technique)
                if summary is None:
                    continue
                pairs = summary.pairs
                error, alpha = pairs.distance_error_pct, pairs.alpha_deg
                row = [
                    cloud.name,
                    beta,
                    label,
                    pairs.blind_pairs,
                    pairs.sweet_pct,
                    pairs.decaying_pct,
                    pairs.no_path_pct,
                    error.mean,
                    error.max,
                    alpha.mean,
                    alpha.max,
                    pairs.obstructed_path_pct,
                    pairs.obstructing_flss_per_path.mean,
                ]
                rows.append(row)
                display_rows.append(
                    [cloud.name, f"{beta:g}", policy, str(row[3])]
                    + [_fmt(value) for value in row[4:7]]
                    + [
                        f"{_fmt(error.mean, 3)} ({_fmt(error.max)})",
                        f"{_fmt(alpha.mean, 3)} ({_fmt(alpha.max)})",
                        _fmt(pairs.obstructed_path_pct, 1),
                    ]
                )
    return Table(
        "errors",
        "Plain Swazure: paths, errors and obstruction per shape, beta and policy",
        columns,
        rows,
        display,
        display_rows,
        "Errors over the pairs that have a path; obstructed: % of pairs with an S_all path "
        "whose policy-shortest S_all path has an obstructed hop.",
    )


def compat_table(plan: StudyPlan, result: SweepResult) -> Table:
    """Each heuristic as the text describes it beside the published code, per shape and beta."""
    policy = plan.heuristic_policy
    texts = [technique for technique in plan.techniques if technique.compat == "text"]
    metrics: tuple[tuple[str, str, Callable[[Summary], Any]], ...] = (
        ("no_path_pct", "no path %", lambda summary: summary.pairs.no_path_pct),
        ("decaying_pct", "decaying %", lambda summary: summary.pairs.decaying_pct),
        ("resolved", "resolved", lambda summary: _facts(summary).resolved_pairs),
        (
            "per_pair_mean_cm",
            "moved per resolved pair, cm",
            lambda summary: _facts(summary).moved_per_resolved_pair.mean,
        ),
        (
            "flown_mean_cm",
            "Move Source flown per tried pair, cm",
            lambda summary: _of(_facts(summary).flown_distance, "mean"),
        ),
    )
    columns = ["shape", "beta", "technique"]
    display = ["shape", "β", "technique"]
    for key, title, _ in metrics:
        columns += [f"{key}_text", f"{key}_published"]
        display.append(f"{title}: text / published")
    rows, display_rows = [], []
    for cloud in plan.clouds:
        for beta in plan.heuristic_betas:
            for technique in texts:
                text = result.find(cloud.name, beta, policy, technique)
                published = result.find(
                    cloud.name, beta, policy, replace(technique, compat="published")
                )
                row: list[Any] = [cloud.name, beta, technique.title]
                cells = [cloud.name, f"{beta:g}", technique.title]
                for key, _, value in metrics:
                    pair = tuple(None if run is None else value(run) for run in (text, published))
                    row += list(pair)
                    digits = 0 if key == "resolved" else 3 if key.endswith("cm") else 2
                    cells.append(" / ".join(_fmt(v, digits) for v in pair))
                rows.append(row)
                display_rows.append(cells)
    return Table(
        "compat_text_vs_published",
        "The heuristics as the text describes them / as the published code runs them",
        columns,
        rows,
        display,
        display_rows,
        f"Policy {policy}; % of ordered blind pairs. The published code's columns are what "
        "the paper's Tables 2 and 3 report; the differences behind them follow the tables.",
    )


def study_tables(plan: StudyPlan, result: SweepResult) -> list[Table]:
    """Every table of the study: paths per technique, distances moved, errors."""
    tables = [paths_table(plan, result, PLAIN_TECHNIQUE)]
    tables += [paths_table(plan, result, technique) for technique in plan.techniques]
    if plan.techniques:
        tables.append(moved_table(plan, result))
    if "published" in plan.compat and plan.techniques:
        tables.append(compat_table(plan, result))
    tables.append(errors_table(plan, result))
    return tables
