"""Options that several verbs share: the swarm's description, the ROS domain, the path
policy, the estimator, the heuristics' threshold and mode, what a picture is coloured by,
and the per-pair output of a run that writes one."""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..api.engine import SwarmSetup, build_swarm
from ..core.clouds import MAX_POINTS, MIN_RESAMPLE
from ..core.errors import SwazureError
from ..core.fit import PATH, SWARM_ESTIMATORS
from ..core.heuristics.compat import COMPAT_MODES
from ..core.paths import POLICIES
from ..files.cloud_files import write_cloud
from ..files.description import DEFAULT_CLOUD
from ..files.results import (
    NO_PAIRS,
    PAIRS_OUTPUTS,
    large_pairs_limit,
    pairs_size_warning,
    write_pair_blocks,
)
from ..files.values import MAX_DOMAIN_ID
from .arguments import (
    check_beta_or_radius,
    domain_id,
    fls_id,
    input_file,
    resample_count,
    seed,
    threshold,
)

if TYPE_CHECKING:
    from collections.abc import Iterator

    from ..core.evaluation import PairResults
    from ..core.heuristics.result import HeuristicResult
    from ..core.neighbourhood import Neighbourhood
    from ..core.pipeline import Take
    from ..sim.world import WorldSpec


def add_swarm_arguments(parser: argparse.ArgumentParser) -> None:
    """Options that describe a swarm: cloud, scale, beta or radius, sensor, seed."""
    parser.add_argument(
        "--cloud",
        default=DEFAULT_CLOUD,
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
        "--seed",
        type=seed,
        default=0,
        help="seed of the choice of colliding FLSs to remove, and of --resample",
    )
    parser.add_argument(
        "--resample",
        type=resample_count,
        default=None,
        metavar="N",
        help=f"a display-size version of the cloud: N points ({MIN_RESAMPLE} to {MAX_POINTS:,}) "
        "over its shape at its own mean spacing (core.clouds.resample: chords' midpoints, "
        "then Poisson-disk thinning in an order seeded by --seed, ties broken by index; the "
        "same N and seed give the same points). Written beside the outputs (--out DIR; "
        "spawn without --out: a temporary folder) as NAME_resampled_N in the cloud's "
        "format, in cm: --cloud that file gives the same swarm",
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


def add_source_body_argument(parser: argparse.ArgumentParser) -> None:
    """Move Source's body rule, shared by the verbs that run the heuristics."""
    parser.add_argument(
        "--source-body",
        action="store_true",
        help="Move Source: take a helper only when the source's own body at its probe point "
        "leaves the helper's view of the target clear, as a swarm flies it (default: the "
        "spec's rule, which does not check it; docs/protocol.md)",
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


def add_pairs_argument(parser: argparse.ArgumentParser) -> None:
    """The per-pair output of ``--out``, shared by the verbs that write a run's pairs."""
    parser.add_argument(
        "--pairs",
        choices=PAIRS_OUTPUTS,
        default=None,
        help="with --out: the per-pair file, pairs.csv (default), pairs.parquet (the same "
        "columns typed, paths as id lists; 2.8x to 5.3x smaller, README) or none "
        "(summary.json and record.json only; record.json says none was written). A run says "
        "on stderr how much it will write before a per-pair file of more than 1 GB",
    )


def pairs_output(args: argparse.Namespace, writes_pairs: bool, needs: str = "--out DIR") -> str:
    """The run's per-pair output: ``--pairs``, or csv when not given.

    SwazureError (exit 2) for ``--pairs`` given to a run that writes no pairs
    (``writes_pairs`` False); ``needs`` names what would make it write them.
    """
    if args.pairs is not None and not writes_pairs:
        raise SwazureError(f"--pairs chooses the per-pair file a run writes: add {needs}")
    if writes_pairs:
        large_pairs_limit()  # a bad $SWAZURE_LARGE_PAIRS_BYTES is refused before the run
    return str(args.pairs or "csv")


def warn_of_large_pairs(verb: str, pairs: int, pairs_format: str) -> None:
    """One line on stderr before a per-pair file larger than the limit is written."""
    warning = pairs_size_warning(pairs, pairs_format, large_pairs_limit())
    if warning is not None:
        print(f"swazure {verb}: {warning}", file=sys.stderr, flush=True)


def pairs_writer(verb: str, args: argparse.Namespace, written: list[Path | None]) -> Take:
    """What writes a run's pairs into ``args.out`` as they come (``--pairs`` says how),
    warning first of a large file; the file goes into ``written`` (None: none)."""

    def take(
        hood: Neighbourhood,
        blocks: Iterator[PairResults],
        heuristic: HeuristicResult | None,
        blind_pairs: int,
    ) -> None:
        warn_of_large_pairs(verb, blind_pairs, args.pairs)
        written.append(
            write_pair_blocks(args.out, hood, args.policy, blocks, args.pairs, heuristic=heuristic)
        )

    return take


def wrote(summary: Path, pairs: Path | None, record: Path) -> str:
    """The line that names a run's files, and says when it wrote no per-pair file."""
    if pairs is None:
        return f"wrote {summary} and {record} (no per-pair file: --pairs {NO_PAIRS})"
    return f"wrote {summary}, {pairs} and {record}"


def swarm_setup_from_args(args: argparse.Namespace) -> SwarmSetup:
    """The swarm that the swarm options describe: its cloud, FLSs and sensor."""
    check_beta_or_radius(args.beta, args.radius)  # refused in the command line's words
    return build_swarm(
        args.cloud,
        args.scale,
        args.beta,
        args.radius,
        args.sensor,
        args.accurate,
        args.seed,
        args.resample,
    )


def written_cloud(setup: SwarmSetup, out: Path | None) -> SwarmSetup:
    """``setup`` with its resampled cloud written into ``out`` (files.cloud_files.write_cloud)
    and named as its source; said on stdout. Unchanged for a cloud not resampled, or no --out."""
    cloud = setup.cloud
    if cloud.resampled is None:
        return setup
    origin = cloud.resampled
    said = (
        f"resampled {origin.cloud} ({origin.points:,} points) to {origin.count:,} at its mean "
        f"spacing, seed {origin.seed}"
    )
    if out is None:
        print(f"{said} (add --out DIR to write it)", flush=True)
        return setup
    path = write_cloud(out, cloud)
    print(f"{said}: wrote {path} (--cloud {path} gives the same swarm)", flush=True)
    return replace(setup, cloud=replace(cloud, source=str(path)))


def add_colour_arguments(parser: argparse.ArgumentParser, default: str, what: str) -> None:
    """How a picture of the swarm colours its FLSs: ``--colour-by`` and ``--seen-from``."""
    parser.add_argument(
        "--colour-by",
        choices=("status", "ranges"),
        default=default,
        help=f"{what}: each FLS's share of blind neighbours with a sweet path (status), or "
        f"range classes seen from FLS --seen-from (ranges); default {default}",
    )
    parser.add_argument(
        "--seen-from",
        type=fls_id,
        default=None,
        metavar="I",
        help="--colour-by ranges: seen from FLS I (default: the first FLS)",
    )


def world_from_args(args: argparse.Namespace) -> WorldSpec:
    """The swarm's description that the swarm options give (add_swarm_arguments)."""
    from ..sim.world import WorldSpec  # here: --help loads no world

    return WorldSpec(
        cloud=args.cloud,
        scale=args.scale,
        beta=args.beta,
        radius=args.radius,
        sensor_file=None if args.sensor is None else str(args.sensor),
        accurate=args.accurate,
        seed=args.seed,
        resample=args.resample,
    )
