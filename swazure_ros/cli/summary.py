"""A run's summary as people read it: a table of rows, and what each row means."""

from __future__ import annotations

import math

from ..core.summary import FitFacts, HeuristicFacts, Summary

#: What the rows of a run's summary mean (spec, sections 2 and 6): ``evaluate --help``.
SUMMARY_TERMS = """\
the summary's rows:
  kissing pairs           unordered pairs that touch: t within 1e-3 cm of 0 (one whose
                          t is still above 0 counts as a blind pair too)
  ordered blind pairs     (source, target) with 0 < t below the sweet range, both orders
  blocked / no sweet path pairs with no sweet path in sight: the radio's sweet graph
                          joins them (an FLS obstructs) / does not
  obstructed sweet paths  of the pairs the radio's sweet graph joins, the share whose
                          path there an FLS obstructs
  predicted error         the estimates' mean expected error, cm; the share of pairs
                          whose error is within theirs
  NEES                    a fit's normalized estimation error squared (3 is honest)
  swarm's iterations      swarm-fit: the iterations of its solves, each one message per
                          FLS to its measured neighbours; the solves: the fit, its
                          reweightings, and the covariance's samples
  distance error, %       | |estimate| - |truth| | / |truth|: 100 % is an estimate twice
                          as long, or of length zero; a decaying hop can exceed that
  sweet error, %          the distance error of the pairs with a sweet path alone
  decaying error, %       the distance error of the pairs with a decaying path alone
  alpha, deg              the angle between the estimated and the true vector
  theta error, deg        the error of the inclination acos(z / |v|)
  phi error, deg          the error of the azimuth atan2(y, x), at most 180: near the z
                          axis a small error of the vector turns the azimuth a lot
"""


def _share(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.1f}"


def cell(value: object) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return "-" if value is None else str(value)


def summary_rows(summary: Summary) -> list[tuple[str, str]]:
    """(label, value) rows of a run's summary, as :func:`summary_table` prints them."""
    pairs = summary.pairs
    rows = [
        ("FLSs (removed)", f"{summary.flss} ({summary.removed})"),
        ("radius r / dmin, cm", f"{summary.radius:.4g} / {summary.dmin:.4g}"),
        ("kissing pairs", cell(summary.kissing_pairs)),
        ("ordered blind pairs", cell(pairs.blind_pairs)),
        ("sweet path", f"{pairs.sweet_pct:.3f} %"),
        ("decaying path", f"{pairs.decaying_pct:.3f} %"),
        ("no path", f"{pairs.no_path_pct:.3f} %"),
        ("blocked / no sweet path", f"{pairs.blocked_pairs} / {pairs.no_sweet_path_pairs}"),
        ("obstructed sweet paths", f"{pairs.obstructed_path_pct:.2f} %"),
        (
            "predicted error cm; within it",
            f"{cell(pairs.predicted_error_cm.mean)}; {_share(pairs.within_predicted_pct)} %",
        ),
    ]
    if summary.fit is not None:
        rows += _fit_rows(summary.fit, summary.parameters.sensor["error_model"]["kind"])
    if summary.fusion is not None:
        fusion = summary.fusion
        one, fused = fusion.distance_error_pct_one_path, fusion.distance_error_pct_fused
        rows.append(
            (
                f"fused ({fusion.paths} paths): pairs",
                f"{fusion.pairs_fused}, error {cell(one.mean)} -> {cell(fused.mean)}",
            )
        )
    if summary.heuristic is not None:
        rows += _heuristic_rows(summary.heuristic)
    for stats, label in [
        (pairs.distance_error_pct, "distance error, %"),
        (pairs.alpha_deg, "alpha, deg"),
        (pairs.theta_deg, "theta error, deg"),
        (pairs.phi_deg, "phi error, deg"),
        (pairs.hops, "hops"),
    ]:
        rows.append((f"{label}: mean / max", f"{cell(stats.mean)} / {cell(stats.max)}"))
        if label == "distance error, %":
            rows += [
                (f"{kind} error, %: mean / max", f"{cell(part.mean)} / {cell(part.max)}")
                for kind, part in (
                    ("sweet", pairs.distance_error_pct_sweet_paths),
                    ("decaying", pairs.distance_error_pct_decaying_paths),
                )
            ]
    return rows


def _fit_rows(fit: FitFacts, error_model: str) -> list[tuple[str, str]]:
    """A fit's rows: its NEES, and the swarm's iterations for swarm-fit."""
    nees = f"{cell(fit.consistency.nees.mean)}; {cell(fit.consistency.within_chi2_95_pct)} %"
    if error_model != "stochastic":
        # The published model's error is one bias, not a spread (docs/core.md).
        nees = "- (no noise model)"
    rows = [("NEES mean; within chi2 95 %", nees)]
    if fit.iterations is not None:
        solves = [count for one in fit.iterations for count in one]
        rows.append(("swarm's iterations (solves)", f"{sum(solves)} ({len(solves)})"))
    return rows


def _heuristic_rows(heuristic: HeuristicFacts) -> list[tuple[str, str]]:
    """A heuristic's rows: its pairs, moves, and the moves of the pairs it did not resolve."""
    moved = heuristic.moved_distance
    per_pair, failed = heuristic.moved_per_resolved_pair, heuristic.failed_moved_distance
    return [
        ("tried / resolved pairs", f"{heuristic.tried_pairs} / {heuristic.resolved_pairs}"),
        ("moves: count, mean, max cm", f"{moved.count}, {cell(moved.mean)}, {cell(moved.max)}"),
        ("per resolved pair: mean, max", f"{cell(per_pair.mean)}, {cell(per_pair.max)}"),
        ("failed pairs' moves: n, mean", f"{failed.count}, {cell(failed.mean)}"),
    ]


def summary_table(
    summary: Summary, *others: tuple[str, Summary], heading: str = "this run"
) -> str:
    """A readable text table of a run's summary (``heading`` over its column, when there are
    ``others``); ``others`` add (heading, summary) columns."""
    columns = [summary_rows(summary)] + [summary_rows(other) for _, other in others]
    width = max(len(value) for column in columns for _, value in column) + 2
    lines = []
    if others:
        headings = [heading] + [other for other, _ in others]
        lines.append(f"{'':<30}" + "".join(f"{title:>{width}}" for title in headings))
    # Rows by label, in order of first appearance: a column may have a row the others lack
    # (the engine's swarm fit counts its iterations), which shows "-" elsewhere.
    labels = list(dict.fromkeys(label for column in columns for label, _ in column))
    values = [dict(column) for column in columns]
    for label in labels:
        lines.append(
            f"{label:<30}" + "".join(f"{column.get(label, '-'):>{width}}" for column in values)
        )
    return "\n".join(lines)
