"""Track a moving FLS out of sight through a relay: true and estimated velocity and acceleration.

The target follows --trajectory (linear:VX,VY,VZ in cm/s; circle:RADIUS,PERIOD
[,AX,AY,AZ] in cm and s, about +z by default; or a waypoint CSV t,x,y,z of s
and cm from home). The source's FLS node, its sweet neighbours (the relays),
the target's node and a simulated clock run over ROS 2 in this process;
--engine runs the core's loop alone. When a relay loses the target, another
takes over if one sees it. Prints the estimates over time and the errors, with and without
delay compensation; --plot FILE.png draws them, --csv FILE writes them.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import SwazureError
from ..core.estimators import MODELS
from ..core.motion import Motion, Trajectory, TrajectoryError
from ..core.tracking import (
    ESTIMATORS,
    TRACK_SETTINGS,
    TrackConfig,
    TrackRun,
    TrackSeries,
    track_errors,
    track_series,
)
from ..files.atomic import atomic_write
from ..files.trajectories import parse_move, parse_trajectory
from .arguments import fls_id, output_file, png_file, seconds
from .options import add_domain_argument, add_swarm_arguments, world_from_args

if TYPE_CHECKING:
    from ..sim.world import World


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``swazure track``."""
    add_swarm_arguments(parser)
    parser.add_argument("--source", type=fls_id, required=True, help="the tracking FLS's id")
    parser.add_argument("--target", type=fls_id, required=True, help="the tracked FLS's id")
    parser.add_argument("--trajectory", required=True, help="the target's motion (see above)")
    parser.add_argument(
        "--move",
        action="append",
        default=[],
        metavar="FLS=TRAJECTORY",
        help="another FLS's motion, e.g. the source's (repeatable)",
    )
    parser.add_argument("--duration", type=seconds, default=10.0, help="simulated s (default 10)")
    defaults = TrackConfig()
    parser.add_argument("--model", choices=MODELS, default=defaults.model, help="filter model")
    for name, meaning in TRACK_SETTINGS.items():
        parser.add_argument(
            f"--{name.replace('_', '-')}",
            type=float,
            default=getattr(defaults, name),
            help=f"{meaning} (default {getattr(defaults, name):g})",
        )
    parser.add_argument("--settle", type=float, default=1.0, help="s before errors count")
    parser.add_argument("--every", type=seconds, default=0.5, help="s between printed rows")
    parser.add_argument("--engine", action="store_true", help="the core's loop, without ROS")
    parser.add_argument(
        "--per-fls",
        action="store_true",
        help="run each FLS taking part in a process of its own (the standalone FLS program)",
    )
    parser.add_argument("--plot", type=png_file, metavar="FILE.png", help="write the figure")
    parser.add_argument("--csv", type=output_file, metavar="FILE", help="write every estimate")
    add_domain_argument(parser)


def _moves(world: World, moves: list[str]) -> dict[int, Trajectory]:
    trajectories = {}
    for move in moves:
        try:
            fls, trajectory = parse_move(move)
        except TrajectoryError as err:
            raise SwazureError(f"--move {err}") from err
        world.index(fls)
        trajectories[fls] = trajectory
    return trajectories


def _config(args: argparse.Namespace) -> TrackConfig:
    return TrackConfig(model=args.model, **{name: getattr(args, name) for name in TRACK_SETTINGS})


def _simulate(world: World, motion: Motion, args: argparse.Namespace) -> TrackRun:
    from ..protocol.loops import simulate_track  # here: --help need not import the world

    return simulate_track(
        world.sensor,
        world.swarm.points,
        world.ids,
        world.swarm.radius,
        motion,
        args.source,
        args.target,
        _config(args),
        args.duration,
    )


def _fmt(vector: np.ndarray) -> str:
    return "(" + ", ".join(f"{value:7.3f}" for value in vector) + ")"


def _print_rows(series: TrackSeries, every: float) -> None:
    print(
        f"{'t s':>6}  {'true velocity cm/s':>27}  {'Kalman velocity':>27}  "
        f"{'true acceleration cm/s^2':>27}  {'Kalman acceleration':>27}"
    )
    next_row = -math.inf
    for row, now in enumerate(series.time.tolist()):
        if now + 1e-9 < next_row:
            continue
        next_row = now + every
        print(
            f"{now:6.2f}  {_fmt(series.truth_velocity[row])}  "
            f"{_fmt(series.velocity['predicted'][row])}  "
            f"{_fmt(series.truth_acceleration[row])}  "
            f"{_fmt(series.acceleration['predicted'][row])}"
        )


def _print_errors(errors: dict[str, dict[str, tuple[float, float]]], settle: float) -> None:
    print(f"\nerror norms after {settle:g} s, mean (max), against the truth now:")
    print(f"{'estimator':<11}{'position cm':>20}{'velocity cm/s':>20}{'accel. cm/s^2':>20}")
    for estimator in ESTIMATORS:
        cells = "".join(
            f"{f'{mean:.4f} ({peak:.4f})':>20}"
            for mean, peak in (errors[quantity][estimator] for quantity in errors)
        )
        print(f"{estimator:<11}{cells}")
    for estimator, meaning in ESTIMATORS.items():
        print(f"  {estimator}: {meaning}")


#: The unit of each quantity of the CSV, as its columns' names end (time in seconds).
CSV_UNITS = {"position": "cm", "velocity": "cm_s", "acceleration": "cm_s2"}


def _write_csv(path: Path, series: TrackSeries) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    columns = ["time_s", "sample_time_s"]
    blocks = [series.time[:, None], series.sample_time[:, None]]
    for quantity, unit in CSV_UNITS.items():
        blocks.append(getattr(series, f"truth_{quantity}"))
        columns += [f"true_{quantity}_{axis}_{unit}" for axis in "xyz"]
        for estimator, values in getattr(series, quantity).items():
            blocks.append(values)
            columns += [f"{estimator}_{quantity}_{axis}_{unit}" for axis in "xyz"]
    writer.writerow(columns)
    writer.writerows(np.hstack(blocks).tolist())
    atomic_write(path, lambda tmp: tmp.write_text(buffer.getvalue()))


def main(args: argparse.Namespace) -> int:
    """Run one track and report it."""
    spec = world_from_args(args)
    if args.per_fls and args.engine:
        raise SwazureError("--per-fls runs the FLSs over ROS; --engine runs the core's loop alone")
    world = spec.build()
    world.index(args.source), world.index(args.target)
    motion = Motion({args.target: parse_trajectory(args.trajectory), **_moves(world, args.move)})
    config = _config(args)
    engine = _simulate(world, motion, args)
    run = engine
    if not args.engine:
        from ..app.track import PerFls, run_track, same_run  # rclpy only when ROS runs

        per_fls = None
        if args.per_fls:
            moves = [f"{args.target}={args.trajectory}", *args.move]
            per_fls = PerFls(spec, ";".join(moves))

        def progress(now: float) -> None:
            print(f"\rsimulated {now:6.2f} / {args.duration:g} s", end="", file=sys.stderr)

        run = run_track(
            world,
            motion,
            args.source,
            args.target,
            config,
            args.duration,
            domain_id=args.domain_id,
            on_progress=progress if sys.stderr.isatty() else None,
            per_fls=per_fls,
        )
        if sys.stderr.isatty():
            print(file=sys.stderr)
    home = world.swarm.points
    series = track_series(
        run, motion, home[world.index(args.source)], home[world.index(args.target)]
    )
    print(
        f"FLS {args.source} tracks FLS {args.target} through relay FLS {run.relay}: "
        f"{args.trajectory}, {config.model}, frame {config.frame_period:g} s, "
        f"delay {config.delay:g} s ({config.sensing_delay:g} sensing + "
        f"{config.communication_delay:g} communication)"
    )
    _print_rows(series, args.every)
    for before, after in zip(run.estimates, run.estimates[1:]):
        if after.relay != before.relay:
            print(
                f"handed over from relay FLS {before.relay} to FLS {after.relay}; first sample "
                f"sensed at {after.sample_time:.2f} s"
            )
    last = run.estimates[-1] if run.estimates else None
    if last is not None and last.message:
        print(f"stream {last.status} at {last.time:.2f} s: {last.message}")
    else:
        print(f"stream {last.status if last else 'empty'}: {len(run.estimates)} estimates")
    _print_errors(track_errors(series, args.settle), args.settle)
    if not args.engine:
        print(f"identical to the core's loop: {'yes' if same_run(run, engine) else 'no'}")
    if args.csv is not None:
        _write_csv(args.csv, series)
        print(f"wrote {args.csv}")
    if args.plot is not None:
        from ..study.figures import track_figure

        title = (
            f"FLS {args.source} tracks FLS {args.target} via FLS {run.relay}: {args.trajectory}, "
            f"{config.model}, delay {config.delay:g} s"
        )
        track_figure(series, title, args.plot)
        print(f"wrote {args.plot}")
    return 0
