"""Evaluate every ordered blind pair of a swarm with the core engine and report the metrics.

The swarm comes from the options or a swarm file (config/swarms/*.yaml), as
for swazure spawn. Prints a summary table; with --out DIR also writes DIR/summary.json,
DIR/record.json and one row per ordered blind pair to DIR/pairs.csv (or pairs.parquet, or
none: --pairs). A progress bar appears on stderr for runs longer than two seconds.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..api.engine import SwarmSetup
from ..core.blocks import DEFAULT_MEMORY, Budget
from ..core.fit import ESTIMATORS, PATH
from ..core.heuristics.result import PLAIN, TECHNIQUES
from ..core.pipeline import AUTO, DECAYING_SEARCHES, EngineRun, RunOptions, run_engine
from ..core.progress import HUNDREDTHS, Progress
from ..files.atomic import write_json
from ..files.reading import available_memory
from ..files.record import RunRecord, write_record
from ..files.results import SUMMARY_FILE
from .arguments import (
    count,
    memory_size,
    output_folder,
    png_file,
)
from .options import (
    add_colour_arguments,
    add_compat_argument,
    add_pairs_argument,
    add_policy_argument,
    add_source_body_argument,
    add_swarm_arguments,
    add_threshold_argument,
    pairs_output,
    pairs_writer,
    swarm_setup_from_args,
    written_cloud,
    wrote,
)
from .summary import SUMMARY_TERMS, cell, explain_run, summary_table
from .swarm_file import add_swarm_file_argument, apply_swarm_file


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
    add_source_body_argument(parser)
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
        "measurement of the swarm; each source's own fit over the measurements it hears "
        "by radio (local-least-squares); or the first fit as the swarm solves it, by "
        "messages between measured neighbours (swarm-fit); the fits give a covariance "
        "per estimate (docs/core.md)",
    )
    parser.add_argument(
        "--out",
        type=output_folder,
        default=None,
        metavar="DIR",
        help="write summary.json, record.json and pairs.csv (--pairs) here",
    )
    add_pairs_argument(parser)
    parser.add_argument(
        "--snapshot",
        type=png_file,
        default=None,
        metavar="FILE.png",
        help="draw the swarm in 3D: FLSs coloured by --colour-by, example paths, and a "
        "heuristic's moves",
    )
    add_colour_arguments(parser, "status", "snapshot colours")
    parser.add_argument(
        "--memory",
        type=memory_size,
        default=DEFAULT_MEMORY,
        metavar="SIZE",
        help="memory a block of plain Swazure's pairs may hold, such as 512M or 4G, from 64M "
        f"to the machine's memory (default {DEFAULT_MEMORY // 2**30}G): a swarm's pairs are "
        "evaluated and written "
        "a block at a time, so a display of 65,536 FLSs fits; the swarm's lean "
        "neighbourhood is held whole besides (docs/core.md, 'The engine at display scale')",
    )
    parser.add_argument(
        "--decaying",
        choices=DECAYING_SEARCHES,
        default=AUTO,
        help="where a run in blocks searches the paths of pairs without a sweet path in "
        "sight, when the swarm's decaying pairs do not fit its memory at once: in those "
        "pairs in sight held whole (held), or each in a region around its pair (near: less "
        "time and memory on a display several sensor reaches wide); auto, the default, is "
        "near for plain Swazure and the heuristics by shortest-length or fewest-hops, held "
        "for the rest; the same paths either way (docs/core.md, 'Decaying paths near their "
        "pairs')",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_swarm_file_argument(
        parser,
        "a swarm file, or an example's name (config/swarms/), as swazure spawn takes it: its "
        "cloud, scale, "
        "beta or radius, sensor, accurate, seed and policy; a flag given here overrides the file",
    )


#: The bar of a stage counted in hundredths of its way (core.progress.Share).
SHARE_BAR = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}<{remaining}]"


class TqdmProgress:
    """Progress bars on stderr, one per stage, shown only for stages longer than 2 s."""

    def __init__(self) -> None:
        self._bar: Any = None

    def start(self, stage: str, total: int) -> None:
        from tqdm import tqdm

        self.close()
        # A stage in hundredths of its way (a solve) has no count of things to show.
        shares = {"bar_format": SHARE_BAR} if total == HUNDREDTHS else {}
        self._bar = tqdm(
            total=total, desc=stage, unit="pair", delay=2.0, file=sys.stderr, leave=False,
            **shares,
        )  # fmt: skip

    def advance(self, units: int) -> None:
        if self._bar is not None:
            self._bar.update(units)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def main(args: argparse.Namespace) -> int:
    """Run ``swazure evaluate``."""
    args = apply_swarm_file(args)
    args.pairs = pairs_output(args, args.out is not None)
    setup = written_cloud(swarm_setup_from_args(args), args.out)
    progress: Progress | None = None if args.quiet else TqdmProgress()
    options = RunOptions(
        args.policy,
        args.technique,
        args.threshold,
        args.compat,
        args.fuse,
        args.estimator,
        args.source_body,
        args.decaying,
    )
    written: list[Path | None] = []  # the per-pair file, once written

    try:
        run = run_engine(
            setup.swarm,
            setup.sensor,
            options,
            hold=args.snapshot is not None,  # a snapshot draws every pair
            take=None if args.out is None else pairs_writer("evaluate", args, written),
            budget=Budget(args.memory, available_memory()),
            source=setup.source,
            progress=progress,
        )
    finally:
        if isinstance(progress, TqdmProgress):
            progress.close()
    summary = run.summary
    record = RunRecord("evaluate", summary.seconds or 0.0, summary, pairs=args.pairs)
    print(_headline(args, setup, record.seconds))
    print(summary_table(summary))
    explain_run("evaluate", summary, setup.swarm, setup.sensor, setup.cloud.scale)
    if args.out is not None:
        summary_path = args.out / SUMMARY_FILE
        write_json(summary_path, summary.as_document())
        print(wrote(summary_path, written[0], write_record(args.out, record)))
    if args.snapshot is not None:
        _snapshot(args, setup, run)
    return 0


def _headline(args: argparse.Namespace, setup: SwarmSetup, seconds: float) -> str:
    technique = args.technique if args.compat == "text" else f"{args.technique} ({args.compat})"
    return (
        f"{setup.cloud.name}: beta {cell(setup.swarm.beta)}, {args.policy}, {technique}, "
        f"{'' if args.estimator == PATH else args.estimator + ', '}"
        f"sensor {setup.sensor.name}, "
        f"{seconds:.2f} s"
    )


def _snapshot(args: argparse.Namespace, setup: SwarmSetup, run: EngineRun) -> None:
    """Draw the swarm of a run that held every pair: FLSs, example paths, a heuristic's moves."""
    from ..view.scene import evaluation_scene
    from ..view.snapshot import write_snapshot

    title = f"{setup.cloud.name}, beta {cell(setup.swarm.beta)}, {args.policy}, {args.technique}"
    scene = evaluation_scene(
        run.held, title, args.colour_by, args.seen_from, heuristic=run.heuristic
    )
    print(f"wrote {write_snapshot(scene, args.snapshot)}")
