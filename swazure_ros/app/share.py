"""One process's share of a swarm: the entry point of each further process of the launcher.

A further process builds the same world from the swarm's :class:`~.config.SwarmConfig`,
hosts its share of FLS nodes, and reports to the launcher over a queue: nodes
created (CREATED), discovery complete with its peak memory and the pairs its world
holds (READY), or one error line (FAILED).
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import resource
import signal
import sys
import threading
from collections.abc import Sequence
from typing import Any

from ..core.errors import RunError, SwazureError
from ..core.geometry import Swarm
from ..core.partition import kd_split
from ..ros.nodes.instance import await_instance
from ..ros.plumbing import process
from ..ros.plumbing.names import host_name
from ..ros.plumbing.process import Context
from ..ros.programs.host import HostConfig, SwarmHost
from ..ros.security.auth import SwarmKey
from .config import SwarmConfig
from .discovery_server import client_environment

CREATED, READY, FAILED = "created", "ready", "failed"


def peak_rss_mb() -> float:
    """This process's peak resident memory, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def init_context(config: SwarmConfig) -> Context:
    """A fresh rclpy context with the swarm's parameter file, domain and discovery."""
    if config.discovery_servers:
        # Read by Fast DDS when the context's participant is made, and by nothing else;
        # a super client, as this process waits until it sees every FLS.
        os.environ.update(client_environment(config.discovery_servers, super_client=True))
    return process.init_context(config.domain_id, config.params_file)


def unreached_text(unreached: list[int], shown: int = 10) -> str:
    """``; FLSs not reached: 3, 17, ... (N)`` for a bring-up's message, or nothing."""
    if not unreached:
        return ""
    more = ", ..." if len(unreached) > shown else ""
    listed = ", ".join(map(str, unreached[:shown]))
    return f"; FLSs not reached: {listed}{more} ({len(unreached)} in all)"


def shares(swarm: Swarm, processes: int) -> list[list[int]]:
    """The FLS ids of ``swarm`` in ``processes`` compact regions of near-equal size.

    Regions (``core.partition.kd_split``), not runs of ids: most of an FLS's
    neighbours are then in its own process, and a process hears the radio
    cells around its region only (``protocol.cells``).
    """
    return [swarm.cloud_index[rows].tolist() for rows in kd_split(swarm.points, processes)]


def announced_instance(config: SwarmConfig, key: bytes) -> bytes:
    """The instance the swarm's world node announces (on the host of share 0)."""
    context = init_context(config)
    try:
        return await_instance(context, config.namespace, key, config.discovery_timeout)
    finally:
        context.try_shutdown()


def host_config(
    config: SwarmConfig,
    fls_ids: Sequence[int],
    index: int,
    swarm_size: int,
    key: SwarmKey,
    world_node: bool = False,
) -> HostConfig:
    """What process ``index`` of a swarm hosts: ``fls_ids`` of its ``swarm_size`` FLSs."""
    return HostConfig(
        fls_ids=tuple(int(fls_id) for fls_id in fls_ids),
        namespace=config.namespace,
        swarm_size=swarm_size,
        with_world_node=world_node,
        name=host_name(index),
        parameters=config.parameters,
        fls_parameters=config.fls_parameters,
        key=key,
        parameter_services=config.parameter_services,
        fls_services=config.fls_services(swarm_size),
    )


def leave_with_launcher(index: int) -> None:
    """Have this further process leave (quietly, exit code 1) once its launcher is gone.

    A launcher stopped in any usual way tells its further processes to stop;
    one killed outright (SIGKILL, the kernel's out-of-memory killer) cannot.
    Its end closes the pipe that multiprocessing's ``sentinel`` is, and a
    thread of this process, waiting on it, ends the process then, even in
    the middle of its bring-up. Without it a further process of torus:10000
    went on for 30 min after the kernel had killed its launcher, 6 GB
    resident and busy (2026-11-29).
    """
    launcher = multiprocessing.parent_process()
    if launcher is None:
        return

    def watch() -> None:
        multiprocessing.connection.wait([launcher.sentinel])
        print(f"process {index}: its launcher is gone; leaving", file=sys.stderr)
        process.leave_quietly(1)

    threading.Thread(target=watch, name="launcher-watch", daemon=True).start()


def host_share(
    config: SwarmConfig,
    key: tuple[bytes | None, bytes],
    index: int,
    fls_ids: list[int],
    swarm_size: int,
    reports: Any,
    stop: Any,
) -> None:
    """Entry point of a further process: host one share until told to stop."""
    # Ctrl-C reaches the whole process group; the launcher decides when we stop.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    leave_with_launcher(index)
    context = host = None
    code = 1
    try:
        # Its FLSs' pairs only, let go once its observations are laid out: only a move asks
        # for them again (at torus:30000 over 4, 1.3 GB a process). Its blind and sweet
        # rows only: the decaying ones when a decaying phase first relays.
        world = config.world.build(
            hosted_ids=fls_ids,
            only_hosted_pairs=True,
            pairs_on_demand=True,
            decaying_on_demand=True,
        )
        context = init_context(config)
        own = host_config(config, fls_ids, index, swarm_size, SwarmKey(*key))
        host = SwarmHost(world, own, context=context)
        host.create_fls_nodes(lambda count: reports.put((CREATED, index, count)))
        if not host.spin_until_discovered(config.discovery_timeout):
            raise RunError(
                f"process {index}: discovery incomplete after {config.discovery_timeout:g} s "
                f"({host.discovery_text()})" + unreached_text(host.unreached())
            )
        reports.put((READY, index, (peak_rss_mb(), world.held())))
        while not stop.is_set():
            host.spin_for(0.1)
        code = 0
    except SwazureError as err:
        reports.put((FAILED, index, str(err)))
    except Exception as err:
        reports.put((FAILED, index, f"process {index}: {type(err).__name__}: {err}"))
    finally:
        # Every report reaches the launcher before the process ends.
        reports.close()
        reports.join_thread()
        process.exit_process(code)
