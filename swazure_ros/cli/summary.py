"""A run's summary as people read it: a table of rows, and what each row means."""

from __future__ import annotations

import math
import sys
import textwrap

from ..core.geometry import Swarm
from ..core.metrics import Stats
from ..core.sensor import Sensor
from ..core.spacing import Advice, likely_unit, run_advice
from ..core.summary import FitFacts, HeuristicFacts, PairStatistics, Summary

#: Every row a run's summary can print, and what it means (spec, sections 2 and 6): the one
#: home of their explanations, printed by the verbs' ``--help`` (:data:`SUMMARY_TERMS`) and
#: copied into docs/core.md (:func:`rows_markdown`; a test holds the two alike). A row
#: shows "-" only with its reason beside it.
SUMMARY_ROWS: tuple[tuple[str, str], ...] = (
    ("FLSs (removed)", "FLSs in the swarm; in brackets the cloud's points removed because "
     "they collided at radius r"),
    ("radius r / dmin, cm", "the FLSs' radius r (beta * dmin, or --radius) and the smallest "
     "distance between two of the cloud's points"),
    ("kissing pairs", "unordered pairs that touch: t within 1e-3 cm of 0 (one whose t is "
     "still above 0 counts as a blind pair too)"),
    ("ordered blind pairs", "(source, target) with 0 < t below the sweet range, both orders: "
     "the pairs the run computes"),
    ("sweet path", "the share of blind pairs joined by a path of sweet hops"),
    ("decaying path", "the share joined only by a path with decaying hops"),
    ("no path", "the share with neither; at 100 % (or with no blind pair) a line under the "
     "table says why, and names --scale when the cloud's spacing does not fit the sensor"),
    ("blocked / no sweet path", "pairs with no sweet path in sight: the radio's sweet graph "
     "joins them (an FLS obstructs) / does not"),
    ("obstructed sweet paths", "of the pairs the radio's sweet graph joins, the share whose "
     "path there an FLS obstructs"),
    ("predicted error cm; within it", "the mean predicted error of the estimates, cm, and "
     "the share of pairs whose error |estimate - truth| is within their own. Of a path's "
     "estimate: its hops' summed errors, a bound under the published bias model (so 100 %) "
     "and a standard deviation under a stochastic sensor (about 61 %); of a fit's: the square "
     "root of its covariance's trace, for a stochastic sensor only: under the bias model the "
     "errors are one bias, not a spread, and the fit's covariance bounds nothing (its "
     "0.0079 cm on the dragon held 9.5 % of errors averaging 0.049 cm), so the row says "
     "\"- (no noise model)\". A heuristic's moved pairs have none: the mean and share are "
     "of the others, the moved counted beside. \"0 (an error-free sensor)\" with --accurate"),
    ("NEES mean; within chi2 95 %", "a fit's normalized estimation error squared e^T C^-1 e "
     "(3 is honest) and its share under the chi-square 95 % bound, 7.81; \"- (no noise "
     "model)\" under the bias model, as above"),
    ("swarm's iterations (solves)", "swarm-fit: the iterations of its solves, each one "
     "message per FLS to its measured neighbours; the solves: the fit, its reweightings, and "
     "the covariance's samples"),
    ("fused pairs; error, %", "--fuse K: the sweet pairs fused from up to K paths, and their "
     "mean distance error with one path -> fused"),
    ("tried / resolved pairs", "a heuristic: the blocked pairs it tried, and those it gave a "
     "path"),
    ("moves: count, mean, max cm", "a heuristic's moves of the resolved pairs, and how far "
     "each moved an FLS"),
    ("per resolved pair: mean, max", "the distance a resolved pair moved in all, cm (the "
     "published Table 3's metric)"),
    ("failed pairs' moves: n, mean", "the moves of the pairs tried and still unresolved, "
     "and their mean distance, cm"),
    ("distance error, %: mean / max", "| |estimate| - |truth| | / |truth| over the pairs with "
     "a path: 100 % is an estimate twice as long, or of length zero; a decaying hop can exceed "
     "that"),
    ("sweet error, %: mean / max", "the distance error of the pairs with a sweet path alone"),
    ("decaying error, %: mean / max", "the distance error of the pairs with a decaying path "
     "alone"),
    ("alpha, deg: mean / max", "the angle between the estimated and the true vector"),
    ("theta error, deg: mean / max", "the error of the inclination acos(z / |v|)"),
    ("phi error, deg: mean / max", "the error of the azimuth atan2(y, x), at most 180: near "
     "the z axis a small error of the vector turns the azimuth a lot"),
    ("hops: mean / max", "the hops of the pairs' paths"),
)  # fmt: skip

#: What a column shows for a row that another column's run has and its own has not.
_ABSENT = "- (not in this run)"


#: Columns of a meaning in ``--help``, indented under its row's label.
_HELP_WIDTH = 84


def _terms() -> str:
    """The rows and their meanings as ``--help`` prints them: label, then wrapped text."""
    lines = ["the summary's rows:"]
    for label, meaning in SUMMARY_ROWS:
        wrapped = textwrap.wrap(meaning, _HELP_WIDTH)
        lines.append(f"  {label}")
        lines += [f"      {line}" for line in wrapped]
    return "\n".join(lines) + "\n"


#: The summary's rows for the ``--help`` (an epilog) of the verbs that print a summary:
#: evaluate, and spawn (--compute-all).
SUMMARY_TERMS = _terms()


def rows_markdown() -> str:
    """The summary's rows as the table docs/core.md holds, word for word."""
    lines = ["| row | what it says |", "| --- | --- |"]
    lines += [
        f"| `{label}` | {meaning.replace('|', chr(92) + '|')} |" for label, meaning in SUMMARY_ROWS
    ]
    return "\n".join(lines) + "\n"


def _share(value: float, why: str = "no prediction") -> str:
    return f"- ({why})" if math.isnan(value) else f"{value:.1f}"


def cell(value: object) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return "-" if value is None else str(value)


def _spread(stats: Stats, why: str) -> str:
    """``mean / max`` of ``stats``, or "-" and ``why`` when it has no values."""
    if not stats.count or stats.mean is None or math.isnan(stats.mean):
        return f"- ({why})"
    return f"{cell(stats.mean)} / {cell(stats.max)}"


def summary_rows(summary: Summary) -> list[tuple[str, str]]:
    """(label, value) rows of a run's summary, as :func:`summary_table` prints them; every
    label is one of :data:`SUMMARY_ROWS`."""
    pairs = summary.pairs
    fit = summary.fit
    rows = [
        ("FLSs (removed)", f"{summary.flss} ({summary.removed})"),
        ("radius r / dmin, cm", f"{summary.radius:.4g} / {summary.dmin:.4g}"),
        ("kissing pairs", cell(summary.kissing_pairs)),
        ("ordered blind pairs", cell(pairs.blind_pairs)),
        ("sweet path", f"{pairs.sweet_pct:.3f} %"),
        ("decaying path", f"{pairs.decaying_pct:.3f} %"),
        ("no path", f"{pairs.no_path_pct:.3f} %"),
        ("blocked / no sweet path", f"{pairs.blocked_pairs} / {pairs.no_sweet_path_pairs}"),
        ("obstructed sweet paths", _obstructed(pairs)),
        ("predicted error cm; within it", _predicted(summary)),
    ]
    if fit is not None:
        rows += _fit_rows(fit, _error_model(summary))
    if summary.fusion is not None:
        fusion = summary.fusion
        one, fused = fusion.distance_error_pct_one_path, fusion.distance_error_pct_fused
        rows.append(
            (
                "fused pairs; error, %",
                f"{fusion.pairs_fused} (up to {fusion.paths} paths); "
                f"{cell(one.mean)} -> {cell(fused.mean)}"
                if fusion.pairs_fused
                else "0 (no sweet pair)",
            )
        )
    if summary.heuristic is not None:
        rows += _heuristic_rows(summary.heuristic)
    for stats, label, why in [
        (pairs.distance_error_pct, "distance error, %", "no pair has a path"),
        (pairs.distance_error_pct_sweet_paths, "sweet error, %", "no sweet path"),
        (pairs.distance_error_pct_decaying_paths, "decaying error, %", "no decaying path"),
        (pairs.alpha_deg, "alpha, deg", "no pair has a path"),
        (pairs.theta_deg, "theta error, deg", "no pair has a path"),
        (pairs.phi_deg, "phi error, deg", "no pair has a path"),
        (pairs.hops, "hops", "no pair has a path"),
    ]:
        rows.append((f"{label}: mean / max", _spread(stats, why)))
    return rows


def _error_model(summary: Summary) -> str:
    """The kind of the run's sensor's error model (polynomial, stochastic, none)."""
    return str(summary.parameters.sensor["error_model"]["kind"])


def _obstructed(pairs: PairStatistics) -> str:
    if not pairs.sweet_connected_pairs:
        return "- (no pair in the sweet graph)"
    return f"{pairs.obstructed_path_pct:.2f} %"


def _predicted(summary: Summary) -> str:
    """The predicted-error row: the mean, the share within it, and the pairs without one."""
    pairs = summary.pairs
    if _error_model(summary) == "none":
        # Every error is rounding (1e-14 %), and whether it is within 0 says nothing.
        return "0 (an error-free sensor)"
    if summary.fit is not None and _error_model(summary) != "stochastic":
        # The bias model's errors are one bias, not a spread: the fit's covariance is what its
        # weights say, and its errors are not within it (9.5 % on the dragon): docs/core.md.
        return "- (no noise model)"
    predicted = pairs.predicted_error_cm
    if not predicted.count:
        return "- (no pair has a path)"
    value = f"{cell(predicted.mean)}; {_share(pairs.within_predicted_pct)} %"
    missing = pairs.sweet_pairs + pairs.decaying_pairs - predicted.count
    if missing > 0:
        value += f" ({missing} moved: none)"
    return value


def _fit_rows(fit: FitFacts, error_model: str) -> list[tuple[str, str]]:
    """A fit's rows: its NEES, and the swarm's iterations for swarm-fit."""
    nees = f"{cell(fit.consistency.nees.mean)}; {_share(fit.consistency.within_chi2_95_pct)} %"
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
        (
            "moves: count, mean, max cm",
            f"{moved.count}, {cell(moved.mean)}, {cell(moved.max)}" if moved.count else "0",
        ),
        (
            "per resolved pair: mean, max",
            f"{cell(per_pair.mean)}, {cell(per_pair.max)}"
            if per_pair.count
            else "- (no pair resolved)",
        ),
        (
            "failed pairs' moves: n, mean",
            f"{failed.count}, {cell(failed.mean)}" if failed.count else "0",
        ),
    ]


def summary_table(
    summary: Summary, *others: tuple[str, Summary], heading: str = "this run"
) -> str:
    """A readable text table of a run's summary (``heading`` over its column, when there are
    ``others``); ``others`` add (heading, summary) columns."""
    columns = [summary_rows(summary)] + [summary_rows(other) for _, other in others]
    # Rows by label, in order of first appearance: a column may have a row the others lack
    # (the engine's swarm fit counts its iterations), which shows _ABSENT elsewhere.
    labels = list(dict.fromkeys(label for column in columns for label, _ in column))
    values = [dict(column) for column in columns]
    shown = [column.get(label, _ABSENT) for column in values for label in labels]
    width = max(len(value) for value in shown) + 2
    lines = []
    if others:
        headings = [heading] + [other for other, _ in others]
        lines.append(f"{'':<30}" + "".join(f"{title:>{width}}" for title in headings))
    for label in labels:
        lines.append(
            f"{label:<30}" + "".join(f"{column.get(label, _ABSENT):>{width}}" for column in values)
        )
    return "\n".join(lines)


def advice_line(advice: Advice, scale: float) -> str:
    """One line: why a run's blind pairs have no path, and the ``--scale`` that would fit the
    sensor (``scale`` is the one the run used: the advice multiplies it)."""
    line = advice.reason
    if advice.factor is not None:
        wanted = float(f"{scale * advice.factor:.2g}")
        line += f"; the cloud's spacing does not fit the sensor: --scale {wanted:g} would"
        if scale != 1.0:
            line += f" ({advice.factor:g} times this run's {scale:g})"
        unit = likely_unit(advice.factor)
        if unit is not None:
            line += f" (is the cloud in {unit}?)"
    return line


def warn(verb: str, advice: Advice | None, scale: float) -> None:
    """Print ``advice`` as a warning on stderr (nothing for None)."""
    if advice is not None:
        print(f"swazure {verb}: warning: {advice_line(advice, scale)}", file=sys.stderr)


def explain_run(
    verb: str, summary: Summary, swarm: Swarm, sensor: Sensor, scale: float, warned: bool = False
) -> None:
    """Say under a run's summary why its every blind pair has no path, or why it has none
    (core.spacing), and warn on stderr unless ``warned`` already. The run still exits 0: it
    completed, and its outputs say what it found."""
    advice = run_advice(summary, swarm, sensor)
    if advice is not None:
        print(f"why: {advice_line(advice, scale)}")
        if not warned:
            warn(verb, advice, scale)
