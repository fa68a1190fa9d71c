"""Bring up a swarm of FLS nodes (one rclpy node per FLS) and serve it until Ctrl-C.

Every FLS publishes its camera measurements on /NAMESPACE/measurements and
answers /NAMESPACE/fls_<id>/get_neighbours; the world node publishes the
positions on /NAMESPACE/world and moves FLSs on /NAMESPACE/move_commands;
the coordinator clocks path discovery and answers
/NAMESPACE/coordinator/compute_pose (docs/protocol.md). FLS ids are the
cloud's row numbers. Node parameters (publish_period, round_timeout) come
from a ROS 2 parameter file (--params, default config/swarm.yaml).

A swarm file (``swazure spawn config/swarms/dragon.yaml``) gives these options
in one YAML file, with every FLS's and single FLSs' parameters; flags given
beside it override it (cli/swarm_file.py; the file's format: files/swarm_file.py).

With --compute-all the swarm computes every FLS's pose relative to every
blind neighbour once (and, with --technique, a heuristic's moves), prints it
beside the core engine's, writes --out like `swazure evaluate`, and exits.
"""

from __future__ import annotations

import argparse
import shutil
import signal
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ..app.config import AUTO, FLS_SERVICES_UP_TO, NEIGHBOUR_SERVICES
from ..core.errors import SwazureError
from ..core.fit import PATH
from ..core.heuristics.result import PLAIN, TECHNIQUES
from ..ros.security.keys import KEY_FILE_VARIABLE
from .arguments import (
    bag_folder,
    check_beta_or_radius,
    count,
    discovery_servers,
    fls_pairs,
    input_file,
    output_folder,
    port,
    ros_namespace,
    seconds,
    share,
)
from .options import (
    add_colour_arguments,
    add_domain_argument,
    add_pairs_argument,
    add_policy_argument,
    add_source_body_argument,
    add_swarm_arguments,
    add_swarm_estimator_argument,
    add_threshold_argument,
    pairs_output,
    world_from_args,
)
from .progress import CreationBar
from .swarm_file import add_swarm_file_argument, apply_swarm_file

if TYPE_CHECKING:
    # Named for the types only: importing them would load rclpy before the verb runs.
    from ..app.config import SwarmConfig
    from ..app.per_fls import Ended
    from ..app.swarm import RunningSwarm, Starting
    from ..files.record import BringUp
    from ..sim.world import World


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure spawn``."""
    from .summary import SUMMARY_TERMS

    # --compute-all prints a summary: its rows are explained as evaluate's are.
    parser.epilog = SUMMARY_TERMS
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    # The launcher leaves its nodes to the process's end (ros.plumbing.process.exit_process).
    parser.set_defaults(exit_process=True)
    add_swarm_arguments(parser)
    add_policy_argument(parser)
    _add_process_arguments(parser)
    _add_bring_up_arguments(parser)
    _add_compute_arguments(parser)
    _add_view_arguments(parser)
    _add_key_arguments(parser)
    _add_fls_process_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_swarm_file_argument(parser)


def _add_process_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of how the swarm's nodes are split: processes, parameters, namespace, hosts."""
    parser.add_argument(
        "--processes", type=count, default=1, metavar="P", help="split the nodes over P processes"
    )
    parser.add_argument(
        "--params",
        type=input_file,
        default=None,
        metavar="FILE",
        help="ROS 2 parameter file (ros__parameters layout; default: config/swarm.yaml)",
    )
    parser.add_argument(
        "--namespace", type=ros_namespace, default="swarm", help="namespace of the swarm's nodes"
    )
    parser.add_argument(
        "--share",
        type=share,
        default=(0, 1),
        metavar="K/N",
        help="host share K of a swarm split over N hosts, each started with the same options "
        "(share 0 runs the world node and the coordinator; README: across hosts)",
    )
    add_domain_argument(parser)


def _add_bring_up_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of waiting for the swarm to come up."""
    parser.add_argument(
        "--until-ready",
        action="store_true",
        help="exit 0 once the whole swarm is up and discovered, after printing the "
        "bring-up time and peak memory",
    )
    parser.add_argument(
        "--discovery-timeout",
        type=seconds,
        default=600.0,
        metavar="S",
        help="give up when the swarm is not discovered after S seconds (default 600)",
    )


def _add_compute_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``--compute-all`` and of what a run writes."""
    parser.add_argument(
        "--compute-all",
        action="store_true",
        help="once the swarm is up, run path discovery for every FLS and blind neighbour "
        "(docs/protocol.md), print its summary next to the core engine's, and exit: "
        "1 when its pairs differ from the engine's or FLSs did not take part",
    )
    parser.add_argument(
        "--technique",
        choices=TECHNIQUES,
        default=PLAIN,
        help="with --compute-all: plain Swazure, or then a heuristic on the BLOCKED pairs, "
        "with the moves made by the swarm (default: plain)",
    )
    add_threshold_argument(parser)
    add_source_body_argument(parser)
    add_swarm_estimator_argument(parser, "with --compute-all: ")
    parser.add_argument(
        "--sources-per-run",
        type=count,
        default=None,
        metavar="N",
        help="with --compute-all: search for at most N sources' targets in one discovery run, "
        "in runs one after the other; each FLS keeps labels for a run's sources only "
        "(default: as many as 1 GiB of labels hold, or 512 MiB a process over three or "
        "more processes or hosts, all of a published shape's; for a larger swarm, the "
        "first run's as if every FLS held every source's label, each later run's by the "
        "memory the labels of the run before took)",
    )
    parser.add_argument(
        "--out",
        type=output_folder,
        default=None,
        metavar="DIR",
        help="write record.json here (the bring-up; with --compute-all also the run, with "
        "summary.json and pairs.csv (--pairs) as swazure evaluate writes them)",
    )
    add_pairs_argument(parser)
    parser.add_argument(
        "--record",
        type=bag_folder,
        default=None,
        metavar="DIR",
        help="record every topic of the swarm to this new bag folder, as ros2 bag record "
        "-s mcap writes one (ros2 bag info and play, rosbags and Foxglove read it); written "
        "whole when the swarm stops",
    )


def _add_view_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``--view``."""
    parser.add_argument(
        "--view",
        action="store_true",
        help="show the swarm: RViz markers on /NAMESPACE/scene (frame 'swarm', metres) and "
        "the same scene live in Foxglove (ws://127.0.0.1:--view-port)",
    )
    parser.add_argument(
        "--view-port", type=port, default=8765, metavar="P", help="Foxglove port (default 8765)"
    )
    add_colour_arguments(parser, "ranges", "--view colours (after --compute-all, the swarm's own)")
    parser.add_argument(
        "--view-pairs",
        type=fls_pairs,
        default=(),
        metavar="I:J,...",
        help="draw the paths of these ordered blind pairs (source:target ids) instead of examples",
    )


def _add_key_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the swarm's key (docs/security.md)."""
    parser.add_argument(
        "--key-file",
        type=input_file,
        default=None,
        metavar="FILE",
        help="the swarm's key (64 hexadecimal digits; make one with `swazure key`): every "
        "protocol message is signed with it and checked (docs/security.md). Default: a fresh "
        f"key for a swarm started here whole; across hosts, ${KEY_FILE_VARIABLE} or none",
    )
    parser.add_argument(
        "--no-key",
        action="store_true",
        help="run without a key: any peer on the ROS domain may then speak for the swarm "
        "(for tools that publish into it, such as ros2 topic pub; docs/security.md)",
    )


def _add_fls_process_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of the FLS nodes and processes, and of DDS discovery."""
    parser.add_argument(
        "--parameter-services",
        action="store_true",
        help="every FLS node answers `ros2 param` (six more services a node: slower "
        "bring-up of a large swarm; BENCHMARKS.md)",
    )
    parser.add_argument(
        "--neighbour-services",
        choices=NEIGHBOUR_SERVICES,
        default=AUTO,
        help="who answers an FLS's get_neighbours: fls, each FLS at "
        "/NAMESPACE/fls_<id>/get_neighbours; hosts, only its process's host node at "
        "/NAMESPACE/host_<k>/get_neighbours (fls_id names the FLS), which spares two "
        f"endpoints an FLS; auto: fls up to {FLS_SERVICES_UP_TO:,} FLSs and with --per-fls, "
        "hosts above (default; host nodes answer in every mode)",
    )
    parser.add_argument(
        "--per-fls",
        action="store_true",
        help="run every FLS in an OS process of its own (the standalone FLS program), as "
        "real FLS hardware does; this process runs the simulator and the coordinator",
    )
    parser.add_argument(
        "--log-dir",
        type=Path,
        default=None,
        metavar="DIR",
        help="--per-fls: write each FLS process's output to DIR/fls_<id>.log, and a "
        "discovery server's to DIR/discovery_server_<i>.log (default: a new temporary "
        "folder, named when the swarm is up, removed when it stops with every FLS process "
        "ended cleanly)",
    )
    parser.add_argument(
        "--discovery-server",
        type=discovery_servers,
        default=(),
        metavar="IP[:PORT],...",
        help="discover through these Fast DDS Discovery Servers (port 11811 unless given; "
        "two or more for redundancy) instead of simple discovery: a server whose address "
        "is this host's is started here; give every host the same list (docs/swarm.md)",
    )


def config_from_args(args: argparse.Namespace, folder: Path | None = None) -> SwarmConfig:
    """The swarm the options describe (a swarm file's, with the flags given over them:
    cli.swarm_file.apply_swarm_file), as a :class:`~swazure_ros.app.config.SwarmConfig`;
    a resampled cloud written into ``folder``, where every process reads it."""
    from ..app.config import SwarmConfig, ViewConfig, params_file
    from ..core.pipeline import RunOptions
    from ..ros.security.keys import key_from

    check_beta_or_radius(args.beta, args.radius)
    if not args.compute_all and (
        args.technique != PLAIN or args.estimator != PATH or args.sources_per_run is not None
    ):
        raise SwazureError("--technique, --estimator and --sources-per-run go with --compute-all")
    RunOptions(  # the engine's rules of what goes together: the swarm is compared with it
        args.policy,
        args.technique,
        args.threshold,
        estimator=args.estimator,
        source_body=args.source_body,
    ).check()
    args.pairs = pairs_output(
        args, args.compute_all and args.out is not None, "--compute-all and --out DIR"
    )
    if args.no_key and args.key_file is not None:
        raise SwazureError("--no-key and --key-file: choose one")
    index, hosts = args.share
    if index > 0 and args.compute_all:
        raise SwazureError("--compute-all runs on share 0, the host with the coordinator")
    if args.log_dir is not None and not (args.per_fls or args.discovery_server):
        raise SwazureError("--log-dir goes with --per-fls or --discovery-server")
    world = world_from_args(args)
    if world.resample is not None:
        if folder is None:
            raise SwazureError("--resample: the swarm's cloud needs a folder to be written to")
        world = world.written(folder)
        print(f"resampled cloud: {world.resampled_file} (--cloud it for the same swarm)")
    if args.compute_all:
        # Before any node comes up, not after: the swarm could not search this way.
        from ..protocol.discovery.buckets import refusal

        refused = refusal(world.sensor(), world.assigned().radius, args.policy)
        if refused is not None:
            raise SwazureError(f"--policy {args.policy}: {refused}")
    return SwarmConfig(
        world,
        processes=args.processes,
        namespace=args.namespace.strip("/") or "swarm",
        params_file=params_file(args.params),
        domain_id=args.domain_id,
        discovery_timeout=args.discovery_timeout,
        share=index,
        hosts=hosts,
        parameters=args.parameters,
        fls_parameters=args.fls_parameters,
        record=None if args.record is None else str(args.record),
        key=key_from(str(args.key_file or "")),
        authenticate=not args.no_key,
        parameter_services=args.parameter_services,
        per_fls=args.per_fls,
        neighbour_services=args.neighbour_services,
        # Only the view and the swarm's heuristics and fits look at every pair at once; the
        # engine's comparison of plain Swazure goes block by block (app.compute).
        whole_world=args.view
        or (args.compute_all and (args.technique != PLAIN or args.estimator != PATH)),
        log_dir=None if args.log_dir is None else str(args.log_dir),
        discovery_servers=args.discovery_server,
        view=ViewConfig(
            args.view_port, args.colour_by, args.seen_from, args.policy, args.view_pairs
        )
        if args.view
        else None,
    )


def warn_spacing(world: World) -> None:
    """Warn on stderr, once the swarm is up, when no pair of its FLSs is a hop the sensor
    measures (every blind pair has no path), naming the --scale that would fit."""
    from ..core.spacing import spacing_advice
    from .summary import warn

    warn("spawn", spacing_advice(world.home, world.sensor), world.cloud.scale)


def report_lost(ended: Ended) -> None:
    """One line when an FLS process of a running swarm ends: the swarm goes on without it."""
    print(f"{ended.describe()}; the swarm goes on without it", file=sys.stderr, flush=True)


def report_ended(ended: list[Ended], log_dir: Path) -> None:
    """One line on how the FLS processes ended: all cleanly, or which did not and where
    their logs are."""
    unclean = [one for one in ended if one.code != 0]
    print(
        f"{len(ended)} FLS processes stopped"
        + ("" if unclean else ", every one cleanly (exit code 0)"),
        file=sys.stderr,
    )
    for one in unclean:
        print(f"  {one.describe()}", file=sys.stderr)
    if unclean:
        print(f"  their logs are in {log_dir}", file=sys.stderr)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _stopper(started: list[Starting]) -> Callable[[int, object], None]:
    """A handler for Ctrl-C and SIGTERM that stops the swarm between spins, not in a callback;
    ``started`` holds the swarm as it comes up, once its host is made."""

    def stop(signum: int, frame: object) -> None:
        if any(swarm.host.defer_stop() for swarm in started):
            return
        raise KeyboardInterrupt

    return stop


def main(args: argparse.Namespace) -> int:
    """Run ``swazure spawn``."""
    # Stop cleanly on Ctrl-C and on SIGTERM (a supervisor, a test), also when a shell
    # that started us in the background made us ignore SIGINT.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _interrupt)
    args = apply_swarm_file(args)
    # A resampled cloud is written beside the outputs, else for the swarm's life only.
    temporary = None
    if args.resample is not None and args.out is None:
        temporary = Path(tempfile.mkdtemp(prefix="swazure-resampled-"))
    try:
        return _spawn(args, config_from_args(args, args.out or temporary))
    finally:
        if temporary is not None:
            shutil.rmtree(temporary, ignore_errors=True)


def _spawn(args: argparse.Namespace, config: SwarmConfig) -> int:
    """Bring the swarm of ``config`` up and serve it, or run ``--compute-all``."""
    # rclpy loads only for the verbs that use it: `swazure evaluate` starts faster.
    from ..app.swarm import RunningSwarm

    bar = CreationBar(args.quiet)
    ready = False
    # The swarm as it comes up, once its host is made: Ctrl-C stops between the host's
    # spins, and how its processes and recording ended is said once it has stopped.
    started: list[Starting] = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _stopper(started))
    try:
        with RunningSwarm.start(
            config, bar, leave_nodes=True, on_lost=report_lost, on_starting=started.append
        ) as swarm:
            bring_up = swarm.bring_up
            if args.out is not None and not args.compute_all:
                # A served swarm's run is its bring-up: what a script reads of it.
                from ..files.record import RunRecord, write_record

                write_record(
                    args.out, RunRecord("spawn", bring_up.seconds, None, bring_up=bring_up)
                )
            ready = True
            bar.close()
            warn_spacing(swarm.world)
            _print_up(swarm, config, bring_up)
            if args.until_ready:
                return 0
            if args.compute_all:
                from .compute_all import compute_all

                return compute_all(swarm, args)
            print(
                f"measurements on /{config.namespace}/measurements; Ctrl-C stops the swarm",
                flush=True,
            )
            swarm.spin()
    except KeyboardInterrupt:
        if not ready:
            raise
        # Ctrl-C or SIGTERM is how a served swarm ends: not an error.
        print("stopping the swarm", file=sys.stderr, flush=True)
    finally:
        bar.close()
        for swarm_start in started:
            _report_stopped(swarm_start)
    return 0


def _print_up(swarm: RunningSwarm, config: SwarmConfig, bring_up: BringUp) -> None:
    """Say that the swarm is up: where, how fast, its peak memory; and where its view is."""
    from ..app.processes import ProcessPerFls

    peaks = " + ".join(f"{mb:.0f}" for mb in bring_up.peak_rss_mb)
    where = (
        f"{bring_up.processes} process(es)"
        if config.hosts == 1
        else f"{config.hosts} hosts (this is share {config.share})"
    )
    if isinstance(swarm.processes, ProcessPerFls):
        fls = swarm.processes.fls
        share = "" if config.hosts == 1 else f", share {config.share} of {config.hosts}"
        where = (
            f"{len(fls.fls_ids)} processes of one FLS each{share} "
            f"(logs in {fls.log_dir}) and this one"
        )
        here, *each = bring_up.peak_rss_mb
        mean = sum(each) / len(each)
        peaks = f"{here:.0f} here, {mean:.0f} per FLS, {max(each):.0f} at most"
    print(
        f"swarm up: {bring_up.flss} FLS nodes in {where} "
        f"under /{config.namespace}, discovered in {bring_up.seconds:.1f} s; "
        f"peak memory {bring_up.total_peak_mb:.0f} MB ({peaks})",
        flush=True,
    )
    if swarm.view is not None:
        live = swarm.view.live
        print(
            f"view: RViz MarkerArray on /{config.namespace}/scene (fixed frame swarm); "
            f"Foxglove ws://127.0.0.1:{live.port if live else '-'}",
            flush=True,
        )


def _report_stopped(swarm: Starting) -> None:
    """Once the swarm has stopped: say how its FLS processes ended, and where its recording
    went (or why it stopped)."""
    from ..app.processes import ProcessPerFls

    processes = swarm.processes
    if isinstance(processes, ProcessPerFls):
        report_ended(processes.ended, processes.fls.log_dir)
    recorder = swarm.recorder
    if recorder is None or not recorder.closed:
        return
    if recorder.stopped is not None:
        # The run's results stand; its recording is what was written before.
        print(f"swazure spawn: warning: {recorder.stopped}", file=sys.stderr)
    else:
        print(
            f"recorded {sum(recorder.counts.values())} messages on "
            f"{len(recorder.counts)} topics ({recorder.bytes / 1e6:.1f} MB of messages) "
            f"to {recorder.path}",
            file=sys.stderr,
        )
