"""Run the published evaluation (spec section 10): every run, tables, figures and a report.

Writes into DIR: runs/<shape>/beta-<b>/<policy>/<technique>/ (summary.json per run,
and pairs.parquet for the runs the figures read, or every run with --keep-pairs),
tables.md with tables/*.csv, figures/*.png and report.md. Runs already in DIR
with the same parameters are not computed again, so an interrupted study
resumes where it stopped.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from ..core.clouds import BUILTIN_SHAPES, Cloud
from ..core.errors import CloudError, SwazureError
from ..core.fit import LEAST_SQUARES, PATH
from ..core.heuristics.compat import COMPAT_MODES
from ..core.paths import POLICIES
from ..files.cloud_files import cloud_files, download_hint, load_cloud, published_dataset_dir
from ..files.results import COMPACT_PAIRS, PAIR_COLUMNS
from ..files.sensors import load_sensor
from ..study.plan import (
    PUBLISHED_BETAS,
    PUBLISHED_HEURISTIC_BETAS,
    PUBLISHED_TECHNIQUES,
    RunSpec,
    StudyPlan,
    Technique,
)
from ..study.sweep import SweepProgress
from .arguments import count, input_file, output_folder, seed

QUICK_BETAS = (0.4, 0.5)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure study``."""
    _add_sweep_arguments(parser)
    _add_run_arguments(parser)
    _add_output_arguments(parser)


def _add_sweep_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of what the study sweeps: clouds, betas, policies, techniques."""
    parser.add_argument(
        "--clouds",
        nargs="+",
        metavar="DIR|FILE|NAME",
        help="folders of point clouds, cloud files or built-in shapes (default: the six "
        "published clouds in ../shared/datasets/swazure-paper when present, else "
        f"{', '.join(BUILTIN_SHAPES)})",
    )
    parser.add_argument(
        "--betas", nargs="+", type=float, metavar="B", help="default: 0.01 0.1 0.2 0.3 0.4 0.5"
    )
    parser.add_argument("--policies", nargs="+", choices=POLICIES, help="default: all three")
    parser.add_argument(
        "--techniques",
        nargs="+",
        metavar="T",
        help="heuristics besides plain Swazure: move-obstructing, move-source[:T] "
        "(default: move-obstructing move-source:2 move-source:10)",
    )
    parser.add_argument(
        "--heuristic-betas",
        nargs="+",
        type=float,
        metavar="B",
        help="betas of the heuristics and tables (default: 0.3 0.4 0.5)",
    )


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of what each run keeps and computes beside plain Swazure."""
    parser.add_argument(
        "--keep-pairs",
        action="store_true",
        help="keep every run's pairs.parquet (about 4.3 GB for the published study); by "
        "default only the runs whose pairs a figure reads keep theirs (the error "
        "histogram's shape at its beta), as every table and other figure comes from the "
        "summaries",
    )
    parser.add_argument(
        "--pair-columns",
        choices=PAIR_COLUMNS,
        default=COMPACT_PAIRS,
        help="per-pair columns kept in a run's pairs.parquet: compact (default; what "
        "nothing else reproduces: ids, status, path, estimate, errors, moves) or full",
    )
    parser.add_argument(
        "--fuse",
        type=count,
        default=1,
        metavar="K",
        help="also fuse every sweet pair's estimate from up to K node-disjoint paths "
        "(--heuristic-policy, every beta), beside the policies in the error figures "
        "(default 1: no fused runs)",
    )
    parser.add_argument(
        "--estimator",
        choices=(PATH, LEAST_SQUARES),
        default=PATH,
        help="least-squares: also estimate every pair by the least-squares fit over the "
        "measurement graph (--heuristic-policy's pairs, every beta), beside the path sums "
        "in the error figures and table, with an error-by-hops figure (default: path only)",
    )
    parser.add_argument(
        "--compat",
        choices=tuple(COMPAT_MODES),
        default="text",
        help="published: run every heuristic also as the paper's published code does, and "
        "report its tables beside the text's (default: text only)",
    )
    parser.add_argument(
        "--heuristic-policy",
        choices=POLICIES,
        default="shortest-length",
        help="path policy of the heuristics and tables (default: shortest-length)",
    )


def _add_output_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the sensor, the seed, where the study goes and how it runs."""
    parser.add_argument(
        "--sensor",
        type=input_file,
        metavar="FILE",
        help="sensor YAML (default: config/sensor.yaml)",
    )
    parser.add_argument("--accurate", action="store_true", help="measure without error")
    parser.add_argument("--seed", type=seed, default=0, help="seed of collision removal")
    parser.add_argument(
        "--out", type=output_folder, default=Path("study"), metavar="DIR", help="default: ./study"
    )
    parser.add_argument(
        "--jobs",
        type=count,
        default=min(2, os.cpu_count() or 1),
        metavar="N",
        help="runs in N parallel processes (default: %(default)s)",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="a small study: the two smallest shapes, beta 0.4 and 0.5 only",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


class SweepBar(SweepProgress):
    """A tqdm bar over the whole sweep, counting runs, on stderr."""

    def __init__(self) -> None:
        self._bar: Any = None

    def start(self, total: int, cached: int) -> None:
        from tqdm import tqdm

        self._bar = tqdm(
            total=total, initial=cached, desc="study", unit="run", file=sys.stderr, leave=True
        )

    def run_done(self, spec: RunSpec, seconds: float) -> None:
        self._bar.set_postfix_str(f"{spec.folder.relative_to('runs')} {seconds:.1f} s")
        self._bar.update(1)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def study_clouds(specs: list[str] | None) -> list[Cloud]:
    """Clouds named on the command line, or the default set."""
    if not specs:
        published = published_dataset_dir()
        specs = [str(published)] if published else list(BUILTIN_SHAPES)
    clouds = []
    for spec in specs:
        path = Path(spec)
        if path.is_dir():
            files = cloud_files(path)
            if not files:
                raise CloudError(f"{path}: no point cloud files (.xyz .csv .npy .ply) in it")
            clouds += [load_cloud(file) for file in files]
        else:
            clouds.append(load_cloud(spec))
    return clouds


def fallback_notice(specs: list[str] | None) -> str | None:
    """Why the study studies the built-in shapes, when it is given no clouds and the six
    published ones are not on this machine; None when it is not falling back."""
    if specs or published_dataset_dir() is not None:
        return None
    return (
        f"the six published clouds are not on this machine, so it studies the built-in "
        f"shapes ({', '.join(BUILTIN_SHAPES)}) instead, whose numbers are not the paper's: "
        f"{download_hint()}"
    )


def plan_from_args(args: argparse.Namespace) -> StudyPlan:
    """The study that the options describe."""
    clouds = study_clouds(args.clouds)
    if args.quick:
        if not args.clouds:
            clouds = sorted(clouds, key=lambda cloud: len(cloud.points))[:2]
        betas = tuple(args.betas or QUICK_BETAS)
        heuristic_betas = tuple(args.heuristic_betas or betas)
    else:
        betas = tuple(args.betas or PUBLISHED_BETAS)
        heuristic_betas = tuple(args.heuristic_betas or PUBLISHED_HEURISTIC_BETAS)
    techniques = (
        tuple(Technique.parse(text) for text in args.techniques)
        if args.techniques
        else PUBLISHED_TECHNIQUES
    )
    sensor = load_sensor(args.sensor)
    if args.accurate:
        sensor = sensor.error_free()
    return StudyPlan(
        clouds,
        sensor,
        betas=betas,
        policies=tuple(args.policies or POLICIES),
        techniques=techniques,
        heuristic_betas=heuristic_betas,
        heuristic_policy=args.heuristic_policy,
        sensor_file=None if args.sensor is None else str(args.sensor),
        seed=args.seed,
        pairs=args.pair_columns,
        keep_pairs=args.keep_pairs,
        compat=tuple(dict.fromkeys(("text", args.compat))),
        fuse=args.fuse,
        least_squares=args.estimator == LEAST_SQUARES,
    )


def main(args: argparse.Namespace) -> int:
    """Run ``swazure study``."""
    plan = plan_from_args(args)
    notice = fallback_notice(args.clouds)
    if notice is not None:
        # The published tables need the published clouds: said before hours of work.
        print(f"swazure study: {notice}", file=sys.stderr, flush=True)
    try:
        from ..study.run import run_study  # here: its figures import matplotlib (0.3 s)

        outputs = run_study(plan, args.out, args.jobs, None if args.quiet else SweepBar())
    except OSError as err:
        raise SwazureError(f"{args.out}: cannot write results ({err.strerror or err})") from err
    result = outputs.result
    print(
        f"{len(result.summaries)} runs: {result.computed} computed "
        f"({result.compute_seconds:.1f} s of computation), {result.cached} cached; "
        f"{result.wall_seconds:.1f} s"
    )
    for table in outputs.tables:
        if table.name != "errors":
            print()
            print(table.to_markdown(), end="")
    print()
    print(f"wrote {outputs.report_path}, {outputs.tables_path}, {len(outputs.figures)} figures")
    return 0
