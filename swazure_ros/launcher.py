"""Bringing a swarm up: FLS nodes in one process or split over several, until discovered.

The launcher's process hosts the world node and the first share of FLS nodes;
each further process (multiprocessing, spawn start method) hosts one more
share. Every process builds the same world from one :class:`WorldSpec`, so
none needs the others' data, and reports to the launcher over a queue: nodes
created, discovery complete (with its peak memory), or one error line. The
swarm is up when every process sees every FLS node's endpoints.
"""

from __future__ import annotations

import multiprocessing
import queue
import resource
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
import yaml
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions

from .core.errors import SwazureError
from .sim.world import WorldSpec

CREATED, READY, FAILED = "created", "ready", "failed"


@dataclass(frozen=True)
class SwarmConfig:
    """How to bring a swarm up."""

    world: WorldSpec
    processes: int = 1
    namespace: str = "swarm"
    params_file: str | None = None
    domain_id: int | None = None
    discovery_timeout: float = 600.0


@dataclass
class BringUp:
    """What bringing the swarm up took."""

    flss: int
    processes: int
    seconds: float  # launcher start to every process discovered
    peak_rss_mb: list[float] = field(default_factory=list)  # per process

    @property
    def total_peak_mb(self) -> float:
        """Sum of the processes' peak resident memory, MB."""
        return float(sum(self.peak_rss_mb))


def peak_rss_mb() -> float:
    """This process's peak resident memory, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def check_params_file(path: Path) -> None:
    """Raise SwazureError unless ``path`` holds ROS 2 parameters (node: ros__parameters: ...)."""
    if not path.is_file():
        raise SwazureError(f"{path}: parameter file not found")
    try:
        document = yaml.safe_load(path.read_text())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        where = getattr(err, "problem_mark", None)
        line = f" (line {where.line + 1})" if where is not None else ""
        raise SwazureError(f"{path}: not a valid ROS 2 parameter file{line}") from err
    if not isinstance(document, dict) or not all(
        isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict)
        for section in document.values()
    ):
        raise SwazureError(
            f"{path}: not a ROS 2 parameter file: expect NODE: {{ros__parameters: {{...}}}}"
        )


def init_context(config: SwarmConfig) -> Context:
    """A fresh rclpy context with the swarm's parameter file and domain."""
    args = []
    if config.params_file is not None:
        # Checked here so that a bad file gives our one line, not rcl's log lines too.
        check_params_file(Path(config.params_file))
        args = ["--ros-args", "--params-file", config.params_file]
    context = Context()
    try:
        rclpy.init(
            args=args,
            context=context,
            domain_id=config.domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
    except Exception as err:  # rclpy reports a bad parameter file as a bare RCLError
        raise SwazureError(f"{config.params_file}: not a valid ROS 2 parameter file") from err
    return context


def shares(fls_ids: np.ndarray, processes: int) -> list[list[int]]:
    """Split FLS ids into ``processes`` contiguous shares of near-equal size."""
    return [part.tolist() for part in np.array_split(np.asarray(fls_ids), processes)]


def _host_share(
    config: SwarmConfig,
    index: int,
    fls_ids: list[int],
    swarm_size: int,
    reports: Any,
    stop: Any,
) -> None:
    """Entry point of a further process: host one share until told to stop."""
    from .nodes.host import SwarmHost

    # Ctrl-C reaches the whole process group; the launcher decides when we stop.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    context = host = None
    try:
        world = config.world.build()
        context = init_context(config)
        host = SwarmHost(
            world,
            fls_ids,
            context=context,
            namespace=config.namespace,
            swarm_size=swarm_size,
            with_world_node=False,
            name=f"host_{index}",
        )
        host.create_fls_nodes(lambda count: reports.put((CREATED, index, count)))
        if not host.spin_until_discovered(config.discovery_timeout):
            published, services = host.discovered()
            raise SwazureError(
                f"process {index}: discovery incomplete after {config.discovery_timeout:g} s "
                f"({published} of {swarm_size} FLS publishers, {services} services)"
            )
        reports.put((READY, index, peak_rss_mb()))
        while not stop.is_set():
            host.spin_for(0.1)
    except SwazureError as err:
        reports.put((FAILED, index, str(err)))
    except Exception as err:
        reports.put((FAILED, index, f"process {index}: {type(err).__name__}: {err}"))
    finally:
        if host is not None:
            host.close()
        if context is not None:
            context.try_shutdown()


class RunningSwarm:
    """A running swarm: the launcher's own share and the further processes.

    Use as a context manager; leaving it stops every process and destroys
    every node.
    """

    def __init__(
        self,
        config: SwarmConfig,
        on_created: Callable[[int, int], None] | None = None,
    ) -> None:
        if config.processes < 1:
            raise SwazureError(f"processes must be at least 1, got {config.processes}")
        self.config = config
        self._on_created = on_created or (lambda created, total: None)
        self._began = time.perf_counter()
        self.world = config.world.build()
        self.size = len(self.world.ids)
        if config.processes > self.size:
            raise SwazureError(f"{config.processes} processes for {self.size} FLSs: too many")
        self._shares = shares(self.world.ids, config.processes)
        self._created = [0] * config.processes
        self._peaks: dict[int, float] = {}
        mp = multiprocessing.get_context("spawn")
        self._reports = mp.Queue()
        self._stop = mp.Event()
        self._children = [
            mp.Process(
                target=_host_share,
                args=(config, index, share, self.size, self._reports, self._stop),
                name=f"swazure-host-{index}",
                daemon=True,
            )
            for index, share in enumerate(self._shares)
            if index > 0
        ]
        self.context: Context | None = None
        self.host: Any = None
        self.coordinator: Any = None  # a CoordinatorThread

    def __enter__(self) -> RunningSwarm:
        try:
            self._start()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def _start(self) -> None:
        from .nodes.coordinator import Coordinator
        from .nodes.host import SwarmHost
        from .nodes.runner import CoordinatorThread

        for child in self._children:
            child.start()
        self.context = init_context(self.config)
        self.host = SwarmHost(
            self.world,
            self._shares[0],
            context=self.context,
            namespace=self.config.namespace,
            swarm_size=self.size,
            name="host_0",
        )

        def created(count: int) -> None:
            self._created[0] = count
            self._drain()

        self.host.create_fls_nodes(created)
        self.coordinator = CoordinatorThread(
            Coordinator(
                self.world.ids.tolist(),
                hosts=self.config.processes,
                world=self.world,
                namespace=self.config.namespace,
                context=self.context,
            )
        )

    def _drain(self) -> None:
        """Take every pending report from the further processes."""
        while True:
            try:
                kind, index, value = self._reports.get_nowait()
            except queue.Empty:
                break
            if kind == FAILED:
                raise SwazureError(value)
            if kind == CREATED:
                self._created[index] = value
            elif kind == READY:
                self._created[index] = len(self._shares[index])
                self._peaks[index] = value
        self._on_created(sum(self._created), self.size)
        for child in self._children:
            if child.exitcode is not None and child.exitcode != 0:
                raise SwazureError(f"{child.name} exited with code {child.exitcode}")

    def wait_until_ready(self) -> BringUp:
        """Spin until every process has discovered the whole swarm; return the bring-up."""
        deadline = time.monotonic() + self.config.discovery_timeout
        discovered = False
        while time.monotonic() < deadline:
            self._drain()
            if not discovered:
                discovered = self.host.is_discovered()
            if discovered and len(self._peaks) == len(self._children):
                self._peaks[0] = peak_rss_mb()
                seconds = time.perf_counter() - self._began
                peaks = [self._peaks[index] for index in range(self.config.processes)]
                return BringUp(self.size, self.config.processes, seconds, peaks)
            self.host.spin_for(0.05)
        publishers, services = self.host.discovered()
        raise SwazureError(
            f"swarm not discovered after {self.config.discovery_timeout:g} s: "
            f"{publishers} of {self.size} FLS publishers and {services} services visible"
        )

    def _spin_step(self, seconds: float) -> None:
        self._drain()
        self.host.spin_for(seconds)

    def discover(self, policy: str, timeout: float | None = None) -> Any:
        """Run discovery for every FLS and blind neighbour; a DiscoveryResult."""
        coordinator = self.coordinator.coordinator
        return self.coordinator.run(coordinator.discover(policy), self._spin_step, timeout)

    def make_moves(
        self,
        plain: Any,
        technique: str = "move-obstructing",
        threshold: int = 10,
        timeout: float | None = None,
    ) -> Any:
        """A heuristic on the BLOCKED pairs of a whole-swarm run, moves made; a MoveResult."""
        coordinator = self.coordinator.coordinator
        moves = coordinator.make_moves(plain, technique, threshold)
        return self.coordinator.run(moves, self._spin_step, timeout)

    def spin(self, seconds: float | None = None) -> None:
        """Serve the swarm for ``seconds`` (for ever when None), watching the processes."""
        deadline = None if seconds is None else time.monotonic() + seconds
        while deadline is None or time.monotonic() < deadline:
            self._drain()
            self.host.spin_for(0.1)

    def close(self) -> None:
        """Stop every process and destroy every node; Ctrl-C waits until this is done."""
        stopping = {signal.SIGINT, signal.SIGTERM}
        signal.pthread_sigmask(signal.SIG_BLOCK, stopping)
        try:
            self._close()
        finally:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, stopping)

    def _close(self) -> None:
        if self.coordinator is not None:
            self.coordinator.close()
            self.coordinator = None
        self._stop.set()
        for child in self._children:
            if child.pid is not None:
                child.join(timeout=30)
                if child.is_alive():
                    child.terminate()
                    child.join(timeout=5)
        if self.host is not None:
            self.host.close()
            self.host = None
        if self.context is not None:
            self.context.try_shutdown()
            self.context = None
