"""Evaluate every ordered blind pair of a swarm with the core engine and report the metrics.

Prints a summary table; with --out DIR also writes DIR/summary.json and one
row per ordered blind pair to DIR/pairs.csv. A progress bar appears on
stderr for runs longer than two seconds.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Any

from ..core.clouds import load_cloud
from ..core.errors import CloudError, SwazureError
from ..core.evaluate import Progress, evaluate
from ..core.fit import ESTIMATORS, LOCAL_LEAST_SQUARES, PATH, SWARM_ESTIMATORS, refine
from ..core.fusion import fuse
from ..core.geometry import make_swarm
from ..core.heuristics.compat import COMPAT_MODES
from ..core.heuristics.folding import run_technique
from ..core.heuristics.result import PLAIN, TECHNIQUES, HeuristicResult
from ..core.paths import POLICIES
from ..core.results import describe_source, write_evaluation
from ..core.sensor import load_sensor
from .arguments import (
    MAX_DOMAIN_ID,
    count,
    domain_id,
    fls_id,
    input_file,
    output_folder,
    png_file,
    seed,
    threshold,
)


def add_swarm_arguments(parser: argparse.ArgumentParser) -> None:
    """Options that describe a swarm: cloud, scale, beta or radius, sensor, seed."""
    parser.add_argument(
        "--cloud",
        default="torus",
        metavar="NAME|PATH",
        help="a point cloud file (.xyz .csv .npy .ply) or a built-in shape "
        "(sphere, torus, helix, cube; NAME:COUNT for another size); default: torus",
    )
    parser.add_argument(
        "--scale",
        type=float,
        default=None,
        help="multiply file coordinates by this to get cm (default: the published "
        "scale for the six published files, else 1)",
    )
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--beta", type=float, default=None, help="FLS radius r = beta * dmin")
    size.add_argument("--radius", type=float, default=None, help="FLS radius r in cm")
    parser.add_argument(
        "--sensor",
        type=input_file,
        default=None,
        metavar="FILE",
        help="sensor YAML (ranges, error model); default: config/sensor.yaml",
    )
    parser.add_argument("--accurate", action="store_true", help="measure without error")
    parser.add_argument(
        "--seed", type=seed, default=0, help="seed of the choice of colliding FLSs to remove"
    )


def add_domain_argument(parser: argparse.ArgumentParser) -> None:
    """The ROS domain option of the verbs that join a swarm."""
    parser.add_argument(
        "--domain-id",
        type=domain_id,
        default=None,
        help=f"ROS domain id, 0..{MAX_DOMAIN_ID} (default: $ROS_DOMAIN_ID)",
    )


def add_swarm_estimator_argument(parser: argparse.ArgumentParser, context: str = "") -> None:
    """``--estimator`` as a swarm runs it: the path sum, or each source's own fit."""
    parser.add_argument(
        "--estimator",
        choices=SWARM_ESTIMATORS,
        default=PATH,
        help=f"{context}how each source estimates a pose: the sum of the measured hops along "
        "the policy's path, as the paper does (default), or a least-squares fit of the "
        "measurements it hears by radio, with a covariance (docs/core.md)",
    )


def add_policy_argument(parser: argparse.ArgumentParser) -> None:
    """The path policy option, shared by the verbs that compute poses."""
    parser.add_argument(
        "--policy",
        choices=POLICIES,
        default="shortest-length",
        help="path policy (default: shortest-length)",
    )


def add_threshold_argument(parser: argparse.ArgumentParser) -> None:
    """Move Source's probe threshold, shared by the verbs that run the heuristics."""
    parser.add_argument(
        "--threshold",
        type=threshold,
        default=10,
        metavar="T",
        help="Move Source: probe up to T steps of r per direction (default 10)",
    )


def add_compat_argument(parser: argparse.ArgumentParser) -> None:
    """The heuristics' mode, shared by the verbs that run them."""
    parser.add_argument(
        "--compat",
        choices=tuple(COMPAT_MODES),
        default="text",
        help="the heuristics as the paper's text describes them (default), or as its "
        "published code runs them, which computed its Tables 2-4 (docs/core.md)",
    )


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
  distance error, %       | |estimate| - |truth| | / |truth|: 100 % is an estimate twice
                          as long, or of length zero; a decaying hop can exceed that
  alpha, deg              the angle between the estimated and the true vector
  theta error, deg        the error of the inclination acos(z / |v|)
  phi error, deg          the error of the azimuth atan2(y, x), at most 180: near the z
                          axis a small error of the vector turns the azimuth a lot
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure evaluate``."""
    parser.epilog = SUMMARY_TERMS
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    add_swarm_arguments(parser)
    add_policy_argument(parser)
    parser.add_argument(
        "--technique",
        choices=TECHNIQUES,
        default=PLAIN,
        help="plain Swazure, or a heuristic tried on BLOCKED pairs (default: plain)",
    )
    add_threshold_argument(parser)
    add_compat_argument(parser)
    parser.add_argument(
        "--fuse",
        type=count,
        default=1,
        metavar="K",
        help="fuse each sweet pair's estimate from up to K node-disjoint sweet paths, "
        "weighted by their expected errors (default 1: the policy's path alone)",
    )
    parser.add_argument(
        "--estimator",
        choices=ESTIMATORS,
        default=PATH,
        help="how a pair's pose is estimated: the sum of the measured hops along the "
        "policy's path, as the paper does (default); a least-squares fit over every "
        "measurement of the swarm; or each source's own fit over the measurements it hears "
        "by radio (local-least-squares); the fits give a covariance per estimate "
        "(docs/core.md)",
    )
    parser.add_argument(
        "--out",
        type=output_folder,
        default=None,
        metavar="DIR",
        help="write summary.json and pairs.csv here",
    )
    parser.add_argument(
        "--snapshot",
        type=png_file,
        default=None,
        metavar="FILE.png",
        help="draw the swarm in 3D: FLSs coloured by --colour-by, example paths, and a "
        "heuristic's moves",
    )
    parser.add_argument(
        "--colour-by",
        choices=("status", "ranges"),
        default="status",
        help="snapshot colours: each FLS's share of blind neighbours with a sweet path "
        "(status), or range classes seen from FLS --fls (ranges)",
    )
    parser.add_argument(
        "--fls", type=fls_id, default=None, metavar="I", help="--colour-by ranges: seen from FLS I"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


class TqdmProgress:
    """Progress bars on stderr, one per stage, shown only for stages longer than 2 s."""

    def __init__(self) -> None:
        self._bar: Any = None

    def start(self, stage: str, total: int) -> None:
        from tqdm import tqdm

        self.close()
        self._bar = tqdm(
            total=total, desc=stage, unit="pair", delay=2.0, file=sys.stderr, leave=False
        )

    def advance(self, units: int) -> None:
        if self._bar is not None:
            self._bar.update(units)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def swarm_from_args(args: argparse.Namespace) -> tuple[Any, Any, Any]:
    """The cloud, swarm and sensor that the swarm options describe."""
    if args.beta is None and args.radius is None:
        raise CloudError("give --beta (r = beta * dmin) or --radius (cm)")
    sensor = load_sensor(args.sensor)
    if args.accurate:
        sensor = sensor.error_free()
    cloud = load_cloud(args.cloud, args.scale)
    swarm = make_swarm(cloud.points, beta=args.beta, radius=args.radius, seed=args.seed)
    return cloud, swarm, sensor


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return "-" if value is None else str(value)


def summary_rows(summary: dict[str, Any]) -> list[tuple[str, str]]:
    """(label, value) rows of a run's summary, as :func:`summary_table` prints them."""
    rows = [
        ("FLSs (removed)", f"{summary['flss']} ({summary['removed']})"),
        ("radius r / dmin, cm", f"{summary['radius']:.4g} / {summary['dmin']:.4g}"),
        ("kissing pairs", _cell(summary["kissing_pairs"])),
        ("ordered blind pairs", _cell(summary["blind_pairs"])),
        ("sweet path", f"{summary['sweet_pct']:.3f} %"),
        ("decaying path", f"{summary['decaying_pct']:.3f} %"),
        ("no path", f"{summary['no_path_pct']:.3f} %"),
        (
            "blocked / no sweet path",
            f"{summary['blocked_pairs']} / {summary['no_sweet_path_pairs']}",
        ),
        ("obstructed sweet paths", f"{summary['obstructed_path_pct']:.2f} %"),
        (
            "predicted error cm; within it",
            f"{_cell(summary['predicted_error_cm']['mean'])}; "
            f"{summary['within_predicted_pct']:.1f} %",
        ),
    ]
    if "fit" in summary:
        fit = summary["fit"]
        kind = summary["parameters"]["sensor"]["error_model"]["kind"]
        nees = f"{_cell(fit['nees']['mean'])}; {_cell(fit['within_chi2_95_pct'])} %"
        if kind != "stochastic":
            # The published model's error is one bias, not a spread (docs/core.md).
            nees = "- (no noise model)"
        rows.append(("NEES mean; within chi2 95 %", nees))
    if "fusion" in summary:
        fusion = summary["fusion"]
        one, fused = fusion["distance_error_pct_one_path"], fusion["distance_error_pct_fused"]
        rows.append(
            (
                f"fused ({fusion['paths']} paths): pairs",
                f"{fusion['pairs_fused']}, error {_cell(one['mean'])} -> {_cell(fused['mean'])}",
            )
        )
    if "technique" in summary:
        moved = summary["moved_distance"]
        rows.append(
            ("tried / resolved pairs", f"{summary['tried_pairs']} / {summary['resolved_pairs']}")
        )
        per_pair, failed = summary["moved_per_resolved_pair"], summary["failed_moved_distance"]
        rows += [
            (
                "moves: count, mean, max cm",
                f"{moved['count']}, {_cell(moved['mean'])}, {_cell(moved['max'])}",
            ),
            (
                "per resolved pair: mean, max",
                f"{_cell(per_pair['mean'])}, {_cell(per_pair['max'])}",
            ),
            (
                "failed pairs' moves: n, mean",
                f"{failed['count']}, {_cell(failed['mean'])}",
            ),
        ]
    for key, label in [
        ("distance_error_pct", "distance error, %"),
        ("alpha_deg", "alpha, deg"),
        ("theta_deg", "theta error, deg"),
        ("phi_deg", "phi error, deg"),
        ("hops", "hops"),
    ]:
        stats = summary[key]
        rows.append((f"{label}: mean / max", f"{_cell(stats['mean'])} / {_cell(stats['max'])}"))
    return rows


def summary_table(summary: dict[str, Any], *others: tuple[str, dict[str, Any]]) -> str:
    """A readable text table of a run's summary; ``others`` add (heading, summary) columns."""
    columns = [summary_rows(summary)] + [summary_rows(other) for _, other in others]
    width = max(len(value) for column in columns for _, value in column) + 2
    lines = []
    if others:
        headings = ["this run"] + [heading for heading, _ in others]
        lines.append(f"{'':<30}" + "".join(f"{heading:>{width}}" for heading in headings))
    for row, (label, _) in enumerate(columns[0]):
        lines.append(f"{label:<30}" + "".join(f"{column[row][1]:>{width}}" for column in columns))
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    """Run ``swazure evaluate``."""
    cloud, swarm, sensor = swarm_from_args(args)
    progress: Progress | None = None if args.quiet else TqdmProgress()
    if args.fuse > 1 and args.technique != PLAIN:
        raise SwazureError("--fuse combines plain Swazure's paths; drop --technique")
    if args.estimator != PATH and (args.fuse > 1 or args.technique != PLAIN):
        raise SwazureError(
            f"--estimator {args.estimator} estimates plain Swazure's pairs; "
            "drop --fuse and --technique"
        )
    if args.compat != "text" and args.technique == PLAIN:
        raise SwazureError(f"--compat {args.compat} changes the heuristics; add --technique")
    heuristic: HeuristicResult | None = None
    try:
        evaluation = evaluate(swarm, sensor, args.policy, progress)
        if args.technique != PLAIN:
            began = time.perf_counter()
            if progress is not None:
                progress.start(args.technique, 1)
            evaluation, heuristic = run_technique(
                evaluation, args.technique, args.threshold, COMPAT_MODES[args.compat]
            )
            evaluation.summary["seconds"] += time.perf_counter() - began
        if args.fuse > 1:
            evaluation = fuse(evaluation, args.fuse)
        if args.estimator != PATH:
            if progress is not None:
                progress.start(args.estimator, 1)
            evaluation = refine(evaluation, local=args.estimator == LOCAL_LEAST_SQUARES)
    finally:
        if isinstance(progress, TqdmProgress):
            progress.close()
    summary = evaluation.summary
    describe_source(summary, cloud, args.seed, args.sensor)
    technique = args.technique if args.compat == "text" else f"{args.technique} ({args.compat})"
    print(
        f"{cloud.name}: beta {_cell(swarm.beta)}, {args.policy}, {technique}, "
        f"{'' if args.estimator == PATH else args.estimator + ', '}"
        f"sensor {sensor.name}, "
        f"{summary['seconds']:.2f} s"
    )
    print(summary_table(summary))
    if args.out is not None:
        try:
            summary_path, pairs_path = write_evaluation(args.out, evaluation, heuristic)
        except OSError as err:
            raise SwazureError(
                f"{args.out}: cannot write results ({err.strerror or err})"
            ) from err
        print(f"wrote {summary_path} and {pairs_path}")
    if args.snapshot is not None:
        from ..view.scene import evaluation_scene
        from ..view.snapshot import write_snapshot

        title = f"{cloud.name}, beta {_cell(swarm.beta)}, {args.policy}, {args.technique}"
        scene = evaluation_scene(evaluation, title, args.colour_by, args.fls, heuristic=heuristic)
        print(f"wrote {write_snapshot(scene, args.snapshot)}")
    return 0
