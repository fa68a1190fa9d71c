"""Evaluate every ordered blind pair of a swarm with the core engine and report the metrics.

The swarm comes from the options or a swarm file (config/swarms/*.yaml), as
for swazure spawn. Prints a summary table; with --out DIR also writes DIR/summary.json and one
row per ordered blind pair to DIR/pairs.csv. A progress bar appears on
stderr for runs longer than two seconds.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from typing import Any

from ..core.blocks import (
    DEFAULT_MEMORY,
    Budget,
    evaluate_blocked,
    whole_swarm_bytes,
)
from ..core.errors import SwazureError
from ..core.evaluate import SILENT, Progress, evaluate
from ..core.fit import ESTIMATORS, PATH, check_plain_estimator, refine
from ..core.fusion import fuse
from ..core.heuristics.compat import COMPAT_MODES
from ..core.heuristics.folding import run_technique
from ..core.heuristics.result import PLAIN, TECHNIQUES, HeuristicResult
from ..core.summary import with_source
from ..files.reading import available_memory
from ..files.results import (
    SUMMARY_FILE,
    RunRecord,
    write_json,
    write_pair_blocks,
    write_record,
    write_run,
)
from .arguments import (
    count,
    memory_size,
    output_folder,
    png_file,
)
from .options import (
    add_colour_arguments,
    add_compat_argument,
    add_policy_argument,
    add_swarm_arguments,
    add_threshold_argument,
    swarm_from_args,
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
    cloud, swarm, sensor = swarm_from_args(args)
    progress: Progress | None = None if args.quiet else TqdmProgress()
    if args.fuse > 1 and args.technique != PLAIN:
        raise SwazureError("--fuse combines plain Swazure's paths; drop --technique")
    check_plain_estimator(args.estimator, args.technique, args.fuse)
    if args.compat != "text" and args.technique == PLAIN:
        raise SwazureError(f"--compat {args.compat} changes the heuristics; add --technique")
    blocked = (
        args.technique == PLAIN
        and args.fuse == 1
        and args.estimator == PATH
        and args.snapshot is None
    )
    try:
        if blocked:
            return _evaluate_in_blocks(args, cloud, swarm, sensor, progress)
        return _evaluate_whole(args, cloud, swarm, sensor, progress)
    finally:
        if isinstance(progress, TqdmProgress):
            progress.close()


def _headline(
    args: argparse.Namespace, cloud: Any, swarm: Any, sensor: Any, seconds: float
) -> str:
    technique = args.technique if args.compat == "text" else f"{args.technique} ({args.compat})"
    return (
        f"{cloud.name}: beta {cell(swarm.beta)}, {args.policy}, {technique}, "
        f"{'' if args.estimator == PATH else args.estimator + ', '}"
        f"sensor {sensor.name}, "
        f"{seconds:.2f} s"
    )


def _evaluate_in_blocks(
    args: argparse.Namespace, cloud: Any, swarm: Any, sensor: Any, progress: Progress | None
) -> int:
    """Plain Swazure a block of pairs at a time: pairs written as they are made."""
    progress = progress or SILENT
    run = evaluate_blocked(swarm, sensor, args.policy, Budget(args.memory), progress)
    pairs_path = None
    if args.out is not None:
        pairs_path = write_pair_blocks(args.out, run.hood, args.policy, run.blocks(progress))
    else:
        for _ in run.blocks(progress):
            pass
    summary = with_source(run.summary(), cloud, args.seed, args.sensor)
    record = RunRecord("evaluate", run.seconds, summary)
    print(_headline(args, cloud, swarm, sensor, record.seconds))
    print(summary_table(summary))
    explain_run("evaluate", summary, swarm, sensor, cloud.scale)
    if args.out is not None:
        summary_path = args.out / SUMMARY_FILE
        write_json(summary_path, summary.as_document())
        record_path = write_record(args.out, record)
        print(f"wrote {summary_path}, {pairs_path} and {record_path}")
    return 0


def _evaluate_whole(
    args: argparse.Namespace, cloud: Any, swarm: Any, sensor: Any, progress: Progress | None
) -> int:
    """A heuristic, fusion, a fit or a snapshot: every pair of the swarm held at once."""
    need, have = whole_swarm_bytes(swarm, sensor), available_memory()
    if need > have:
        raise SwazureError(
            f"{cloud.name}: --technique, --fuse, --estimator and --snapshot hold every pair "
            f"of the swarm at once, about {need / 2**30:.1f} GB for {swarm.size} FLSs; this "
            f"machine has {have / 2**30:.1f} GB free (plain Swazure runs in blocks)"
        )
    heuristic: HeuristicResult | None = None
    evaluation = evaluate(swarm, sensor, args.policy, progress)
    if args.technique != PLAIN:
        began = time.perf_counter()
        if progress is not None:
            progress.start(args.technique, 1)
        evaluation, heuristic = run_technique(
            evaluation, args.technique, args.threshold, COMPAT_MODES[args.compat]
        )
        seconds = (evaluation.summary.seconds or 0.0) + time.perf_counter() - began
        evaluation = replace(evaluation, summary=replace(evaluation.summary, seconds=seconds))
    if args.fuse > 1:
        evaluation = fuse(evaluation, args.fuse)
    if args.estimator != PATH:
        if progress is not None:
            progress.start(args.estimator, 1)
        evaluation = refine(evaluation, args.estimator)
    if isinstance(progress, TqdmProgress):
        progress.close()
    summary = with_source(evaluation.summary, cloud, args.seed, args.sensor)
    evaluation = replace(evaluation, summary=summary)
    record = RunRecord("evaluate", summary.seconds or 0.0, summary)
    print(_headline(args, cloud, swarm, sensor, record.seconds))
    print(summary_table(summary))
    explain_run("evaluate", summary, swarm, sensor, cloud.scale)
    if args.out is not None:
        summary_path, pairs_path, record_path = write_run(args.out, evaluation, record, heuristic)
        print(f"wrote {summary_path}, {pairs_path} and {record_path}")
    if args.snapshot is not None:
        from ..view.scene import evaluation_scene
        from ..view.snapshot import write_snapshot

        title = f"{cloud.name}, beta {cell(swarm.beta)}, {args.policy}, {args.technique}"
        scene = evaluation_scene(
            evaluation, title, args.colour_by, args.seen_from, heuristic=heuristic
        )
        print(f"wrote {write_snapshot(scene, args.snapshot)}")
    return 0
