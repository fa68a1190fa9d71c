"""Evaluate every ordered blind pair of a swarm with the core engine and report the metrics.

The swarm comes from the options or a swarm file (config/swarms/*.yaml), as
for swazure spawn. Prints a summary table; with --out DIR also writes DIR/summary.json,
DIR/record.json and one row per ordered blind pair to DIR/pairs.csv (or pairs.parquet, or
none: --pairs). A progress bar appears on stderr for runs longer than two seconds.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..api.engine import RunOptions, SwarmSetup, run_blocked, run_whole
from ..core.blocks import DEFAULT_MEMORY
from ..core.evaluation import PairResults
from ..core.fit import ESTIMATORS, PATH
from ..core.heuristics.result import PLAIN, TECHNIQUES
from ..core.neighbourhood import Neighbourhood
from ..core.progress import SILENT, Progress
from ..files.atomic import write_json
from ..files.record import write_record
from ..files.results import SUMMARY_FILE, write_pair_blocks, write_run
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
    add_swarm_arguments,
    add_threshold_argument,
    pairs_output,
    swarm_setup_from_args,
    warn_of_large_pairs,
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
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_swarm_file_argument(
        parser,
        "a swarm file, or an example's name (config/swarms/), as swazure spawn takes it: its "
        "cloud, scale, "
        "beta or radius, sensor, accurate, seed and policy; a flag given here overrides the file",
    )


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


def main(args: argparse.Namespace) -> int:
    """Run ``swazure evaluate``."""
    args = apply_swarm_file(args)
    args.pairs = pairs_output(args, args.out is not None)
    setup = swarm_setup_from_args(args)
    progress: Progress | None = None if args.quiet else TqdmProgress()
    options = RunOptions(
        args.policy, args.technique, args.threshold, args.compat, args.fuse, args.estimator
    )
    options.check()
    try:
        if options.blocked and args.snapshot is None:
            return _evaluate_in_blocks(args, setup, progress)
        return _evaluate_whole(args, setup, options, progress)
    finally:
        if isinstance(progress, TqdmProgress):
            progress.close()


def _headline(args: argparse.Namespace, setup: SwarmSetup, seconds: float) -> str:
    technique = args.technique if args.compat == "text" else f"{args.technique} ({args.compat})"
    return (
        f"{setup.cloud.name}: beta {cell(setup.swarm.beta)}, {args.policy}, {technique}, "
        f"{'' if args.estimator == PATH else args.estimator + ', '}"
        f"sensor {setup.sensor.name}, "
        f"{seconds:.2f} s"
    )


def _evaluate_in_blocks(
    args: argparse.Namespace, setup: SwarmSetup, progress: Progress | None
) -> int:
    """Plain Swazure a block of pairs at a time: pairs written as they are made."""

    def take(hood: Neighbourhood, blocks: Iterator[PairResults], blind_pairs: int) -> Path | None:
        if args.out is None:
            for _ in blocks:
                pass
            return None
        warn_of_large_pairs("evaluate", blind_pairs, args.pairs)
        return write_pair_blocks(args.out, hood, args.policy, blocks, args.pairs)

    record, pairs_path = run_blocked(setup, args.policy, args.memory, progress or SILENT, take)
    record = replace(record, pairs=args.pairs)
    summary = record.summary
    assert summary is not None  # an evaluation's record has its summary
    print(_headline(args, setup, record.seconds))
    print(summary_table(summary))
    explain_run("evaluate", summary, setup.swarm, setup.sensor, setup.cloud.scale)
    if args.out is not None:
        summary_path = args.out / SUMMARY_FILE
        write_json(summary_path, summary.as_document())
        record_path = write_record(args.out, record)
        print(wrote(summary_path, pairs_path, record_path))
    return 0


def _evaluate_whole(
    args: argparse.Namespace, setup: SwarmSetup, options: RunOptions, progress: Progress | None
) -> int:
    """A heuristic, fusion, a fit or a snapshot: every pair of the swarm held at once."""
    evaluation, heuristic, record = run_whole(setup, options, progress)
    if isinstance(progress, TqdmProgress):
        progress.close()
    record = replace(record, pairs=args.pairs)
    print(_headline(args, setup, record.seconds))
    print(summary_table(evaluation.summary))
    explain_run("evaluate", evaluation.summary, setup.swarm, setup.sensor, setup.cloud.scale)
    if args.out is not None:
        warn_of_large_pairs("evaluate", evaluation.summary.pairs.blind_pairs, args.pairs)
        print(wrote(*write_run(args.out, evaluation, record, heuristic)))
    if args.snapshot is not None:
        from ..view.scene import evaluation_scene
        from ..view.snapshot import write_snapshot

        swarm = setup.swarm
        title = f"{setup.cloud.name}, beta {cell(swarm.beta)}, {args.policy}, {args.technique}"
        scene = evaluation_scene(
            evaluation, title, args.colour_by, args.seen_from, heuristic=heuristic
        )
        print(f"wrote {write_snapshot(scene, args.snapshot)}")
    return 0
