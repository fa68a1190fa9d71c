"""``swazure spawn --compute-all``: the swarm's discovery beside the engine, printed and
written: what the verb prints as it goes, the summary beside the engine's, --out."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..core.fit import PATH
from ..files.record import RunRecord
from .options import pairs_writer, wrote

if TYPE_CHECKING:
    from ..app.swarm import RunningSwarm
    from ..protocol.runs import DiscoveryResult
    from ..sim.world import World


def compute_all(swarm: RunningSwarm, args: argparse.Namespace) -> int:
    """Run discovery over the whole swarm, report it beside the engine, write --out."""
    from ..app.compute import compute_all as run
    from ..app.compute import run_failure

    began = time.monotonic()

    def progress(text: str) -> None:
        if not args.quiet:
            print(f"  {time.monotonic() - began:.0f} s: {text}", file=sys.stderr, flush=True)

    first, live = swarm.first_block(args.sources_per_run, estimator=args.estimator)
    runs = ""
    if len(first) < len(live):
        runs = f", in runs of {len(first):,} sources" + (
            "" if args.sources_per_run else " first, then as many as the labels' memory allows"
        )
    print(f"discovery: every FLS for every blind neighbour, {args.policy}{runs}", flush=True)
    written: list[Path | None] = []  # the per-pair file, once written
    computed = run(
        swarm,
        args.policy,
        args.technique,
        args.threshold,
        _discovered(swarm.world, args.policy),
        progress,
        args.estimator,
        args.sources_per_run,
        args.source_body,
        None if args.out is None else pairs_writer("spawn", args, written),
    )
    record = computed.record
    _report(record, swarm.world, args)
    if args.out is not None:
        from ..files.atomic import write_json
        from ..files.record import write_record
        from ..files.results import SUMMARY_FILE

        assert record.summary is not None  # a run of the swarm's has one
        summary_path = args.out / SUMMARY_FILE
        write_json(summary_path, record.summary.as_document())
        record = replace(record, pairs=args.pairs)
        print(wrote(summary_path, written[0], write_record(args.out, record)))
    # The outputs stay written (they show what went wrong); the exit code says it.
    failure = run_failure(record)
    if failure is not None:
        print(f"swazure spawn: error: {failure}", file=sys.stderr)
        return 1
    return 0


def _discovered(world: World, policy: str) -> Callable[[DiscoveryResult], None]:
    """What prints the line of a discovery run's result, as soon as it is in."""
    beta = world.swarm.beta
    size = f"radius {world.swarm.radius:.4g} cm" if beta is None else f"beta {beta:.4g}"

    def discovered(result: DiscoveryResult) -> None:
        traffic, outcome = result.traffic, result.outcome
        print(
            f"{world.cloud.name}: {size}, {policy}: discovery "
            f"{result.seconds:.2f} s, "
            + (f"{result.runs} runs, " if result.runs > 1 else "")
            + f"{outcome.rounds} rounds, {traffic.total_messages} "
            f"messages, {traffic.total_bytes / 1e6:.1f} MB; labels held "
            f"{outcome.label_bytes / 1e6:.1f} MB at most"
            + (f", {outcome.repairs} radio repairs" if outcome.repairs else "")
            + (" - INCOMPLETE: radio deliveries lost for good" if outcome.incomplete else ""),
            flush=True,
        )

    return discovered


def _report(record: RunRecord, world: World, args: argparse.Namespace) -> None:
    """Print the moves made, the engine's time, the summary beside the engine's and whether
    every pair is the engine's."""
    from .summary import explain_run, summary_table

    moved = record.distributed.moves if record.distributed is not None else None
    if moved is not None:
        print(
            f"{args.technique}: {moved.seconds:.2f} s, {moved.batches} batches, "
            f"{moved.move_commands} move commands, {moved.path_walks} path walks, "
            f"{moved.total_messages} messages, {moved.total_bytes / 1e6:.1f} MB"
            + (f", {moved.timeouts} waits timed out" if moved.timeouts else "")
        )
    assert record.summary is not None and record.engine is not None
    assert record.engine_seconds is not None and record.comparison is not None
    print(f"engine: {record.engine_seconds:.2f} s for the same work")
    print(summary_table(record.summary, ("engine", record.engine), heading="distributed"))
    # Warned as the swarm came up (warn_spacing): here the line under the summary.
    explain_run("spawn", record.engine, world.home, world.sensor, world.cloud.scale, warned=True)
    print(
        "pairs identical to the engine's (status, path, estimate to 1e-9"
        + (", covariance" if args.estimator != PATH else "")
        + f"): {record.comparison.describe()}"
    )
