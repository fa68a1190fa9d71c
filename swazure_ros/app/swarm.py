"""Running a swarm: bring it up over one or more processes, and compute with it.

The launcher's process hosts the world node and the first share of FLS nodes;
each further process (multiprocessing, spawn start method) hosts one more
share. Every process builds the same world from one :class:`WorldSpec`, so
none needs the others' data, and lays out what its own share senses (the
race car's whole swarm's observations are 650 MB), and reports to the launcher over a queue: nodes
created, discovery complete (with its peak memory), or one error line. The
swarm is up when every process sees every FLS node's endpoints.

:meth:`RunningSwarm.discover` and :meth:`RunningSwarm.make_moves` run the
coordinator's protocols over the swarm (:mod:`.compute` sets a whole swarm's
run beside the engine's).
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..core.errors import RunError, SwazureError
from ..core.evaluate import Evaluation, evaluate
from ..core.fit import PATH
from ..core.results import BringUp
from ..protocol.runs import DiscoveryResult, MoveResult, merged, source_blocks, sources_per_run
from ..ros.auth import SwarmKey, new_key
from ..ros.bag import Recorder
from ..ros.coordinator import Coordinator, Future
from ..ros.host import SwarmHost
from ..ros.names import host_name
from ..ros.runtime import Context
from ..ros.view import ViewNode
from ..ros.world_node import SimulatedCameras
from ..sim.world import World
from ..view.scene import Scene, evaluation_scene, ranges_scene
from .config import SwarmConfig, ViewConfig
from .discovery_server import DiscoveryServers
from .per_fls import Ended, FlsProcesses
from .share import (
    CREATED,
    FAILED,
    READY,
    announced_instance,
    host_share,
    init_context,
    peak_rss_mb,
    shares,
    unreached_text,
)

#: Seconds between two progress reports of a long run.
PROGRESS_PERIOD = 10.0


class RunningSwarm:
    """A running swarm: the launcher's own share and the further processes.

    Use as a context manager; leaving it stops every process and destroys
    every node.
    """

    def __init__(
        self,
        config: SwarmConfig,
        on_created: Callable[[int, int], None] | None = None,
        leave_nodes: bool = False,
        on_lost: Callable[[Ended], None] | None = None,
    ) -> None:
        self.config = config
        # A process that ends right after the swarm leaves its own nodes to
        # runtime.exit_process: far faster than destroying them one by one.
        self._leave_nodes = leave_nodes
        self._on_created = on_created or (lambda created, total: None)
        self._on_lost = on_lost or (lambda ended: None)
        #: Up and discovered (wait_until_ready); per_fls: the FLS processes that ended since.
        self.ready = False
        self.lost: list[Ended] = []
        self._began = time.perf_counter()
        assigned = config.world.assigned()
        fls_ids = assigned.cloud_index
        self.size = len(fls_ids)
        parts = max(config.processes, config.hosts)
        if parts > self.size:
            raise SwazureError(f"{parts} shares for {self.size} FLSs: too many")
        strangers = sorted(set(config.fls_parameters) - set(fls_ids.tolist()))
        if strangers:
            raise SwazureError(
                f"parameters for FLS {strangers[0]}: no such FLS in this swarm of {self.size} "
                f"(ids {fls_ids[0]}..{fls_ids[-1]})"
            )
        self._shares = shares(assigned, parts)
        if config.hosts > 1:
            # Only this host's share here; the others run on their own hosts.
            self._shares = [self._shares[config.share]]
        key = config.key if config.authenticate else None
        if key is None and config.authenticate and config.hosts == 1:
            key = new_key()
        instance = None  # a fresh one: this swarm's life
        if key is not None and config.share != 0:
            # A further host of a swarm that shares a key file: the world node's.
            instance = announced_instance(config, key)
        self.key = SwarmKey(key, instance)
        self.fls_processes: FlsProcesses | None = None
        # A folder for the logs of the processes started here, if any are.
        started = config.per_fls or bool(config.discovery_servers)
        log_dir = Path(config.log_dir or (tempfile.mkdtemp(prefix="swazure-") if started else "."))
        self.discovery_servers = DiscoveryServers(config.discovery_servers, log_dir)
        if config.per_fls:
            # This host's FLS processes; share 0 also simulates every FLS's camera.
            self.fls_processes = FlsProcesses(
                config.world,
                self._shares[0],
                log_dir,
                namespace=config.namespace,
                key=self.key,
                parameters=config.parameters,
                fls_parameters=config.fls_parameters,
                params_file=config.params_file,
                domain_id=config.domain_id,
                discovery_servers=config.discovery_servers,
            )
            self._shares = [[]]
        # Each process lays out what its own FLSs sense; the coordinator's
        # planning and the engine's comparison need the neighbourhood, not that.
        hosted = None if config.per_fls else self._shares[0]
        self.world = config.world.build(hosted_ids=hosted)
        self._created = [0] * config.processes
        self._peaks: dict[int, float] = {}
        mp = multiprocessing.get_context("spawn")
        self._reports = mp.Queue()
        self._stop = mp.Event()
        material = self.key.material  # each further process signs as a sender of its own
        self._children = [
            mp.Process(
                target=host_share,
                args=(config, material, index, share, self.size, self._reports, self._stop),
                name=f"swazure-host-{index}",
                daemon=True,
            )
            for index, share in enumerate(self._shares)
            if index > 0
        ]
        self.context: Context | None = None
        #: per_fls: how every FLS process ended, once the swarm is closed.
        self.ended: list[Ended] = []
        self.host: SwarmHost | None = None
        self.coordinator: Coordinator | None = None
        self.recorder: Recorder | None = None
        self.view: ViewNode | None = None
        self.bring_up: BringUp | None = None  # once every process is ready

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
        self.discovery_servers.start()
        for child in self._children:
            child.start()
        if self.fls_processes is not None:
            self.fls_processes.start()
        self.context = init_context(self.config)
        leader = self.config.share == 0
        self.host = SwarmHost(
            self.world,
            self._shares[0],
            context=self.context,
            namespace=self.config.namespace,
            swarm_size=self.size,
            with_world_node=leader,
            name=host_name(self.config.share),
            parameters=self.config.parameters,
            fls_parameters=self.config.fls_parameters,
            key=self.key,
            parameter_services=self.config.parameter_services,
        )

        def created(count: int) -> None:
            self._created[0] = count
            self._drain()

        if leader and self.config.record is not None:
            # Before the nodes: it hears every topic from its first publisher on.
            self.recorder = Recorder(
                Path(self.config.record), self.config.namespace, context=self.context
            )
            self.host.add(self.recorder)
        self.host.create_fls_nodes(created)
        if self.fls_processes is not None and leader:
            cameras = SimulatedCameras(
                self.host.replica,
                self.world.ids.tolist(),
                namespace=self.config.namespace,
                context=self.context,
                key=self.key,
            )
            self.host.add(cameras)
        if leader:
            self.coordinator = Coordinator(
                self.world.ids.tolist(),
                hosts=self._hosts,
                shape=self.world.home_hood,
                namespace=self.config.namespace,
                context=self.context,
                key=self.key,
                # One node: ros2 param reaches it in every mode, at six services' cost.
                parameter_services=True,
            )
            self.host.add(self.coordinator)
            if self.config.view is not None:
                self.view = ViewNode(
                    first_scene(self.world, self.config.view),
                    namespace=self.config.namespace,
                    context=self.context,
                    port=self.config.view.port,
                    key=self.key,
                )
                self.host.add(self.view)

    @property
    def process_ids(self) -> list[int]:
        """The pids of this swarm's packed processes: this one, then each further share's."""
        return [os.getpid(), *(child.pid for child in self._children if child.pid is not None)]

    @property
    def _hosts(self) -> int:
        """Processes whose radios take part in a run: one per share, or per FLS."""
        if self.config.per_fls:
            return self.size
        return max(self.config.processes, self.config.hosts)

    def _drain(self) -> None:
        """Take every pending report from the further processes."""
        if self.fls_processes is not None:
            known = {one.fls_id for one in self.lost}
            ended = [one for one in self.fls_processes.ended() if one.fls_id not in known]
            if ended and not self.ready:
                # While it comes up, an FLS that ends has a fault to fix: stop and say which.
                raise RunError(
                    f"{ended[0].describe()} (log: {self.fls_processes.log(ended[0].fls_id)})"
                )
            # Once up, an FLS that ends is an FLS lost, as in flight: the swarm's rounds
            # find it silent and go on without it (docs/protocol.md, departures).
            for one in ended:
                self.lost.append(one)
                self._on_lost(one)
            if self.host is not None and not self.ready:
                self._on_created(min(self.host.discovered()[0], self.size), self.size)
            return
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
                raise RunError(f"{child.name} exited with code {child.exitcode}")

    def wait_until_ready(self) -> BringUp:
        """Spin until every process has discovered the whole swarm; return the bring-up."""
        deadline = time.monotonic() + self.config.discovery_timeout
        discovered = False
        while time.monotonic() < deadline:
            self._drain()
            if not discovered:
                discovered = self._host.is_discovered()
            # Seeing every node is not enough: a host whose radio has not matched the
            # coordinator's controls yet would miss a run's START (shares on other hosts).
            matched = self.coordinator is None or self.coordinator.hosts_matched()
            # A recording starts with everything the run publishes.
            matched = matched and (self.recorder is None or self.recorder.caught_up())
            if discovered and matched and len(self._peaks) == len(self._children):
                self._peaks[0] = peak_rss_mb()
                seconds = time.perf_counter() - self._began
                peaks = [self._peaks[index] for index in range(self.config.processes)]
                if self.fls_processes is not None:
                    peaks += self.fls_processes.peak_rss_mb()
                self.ready = True
                self.bring_up = BringUp(self.size, len(peaks), seconds, peaks)
                return self.bring_up
            self._host.spin_for(0.05)
        publishers, services = self._host.discovered()
        raise RunError(
            f"swarm not discovered after {self.config.discovery_timeout:g} s: "
            f"{publishers} of {self.size} FLS publishers and {services} services visible"
            + unreached_text(self._host.unreached())
        )

    @property
    def _host(self) -> SwarmHost:
        if self.host is None:
            raise SwazureError("the swarm is not running")
        return self.host

    @property
    def _coordinator(self) -> Coordinator:
        if self.coordinator is None:
            raise SwazureError("the swarm is not running")
        return self.coordinator

    def run(
        self,
        run: Future,
        timeout: float | None = None,
        step: Callable[[], None] | None = None,
        on_progress: Callable[[str], None] | None = None,
    ) -> Any:
        """Serve the swarm until the coordinator's ``run`` is done; its result.

        ``step()`` is called between spins (a test stops a node there);
        ``on_progress`` hears how far the run is every PROGRESS_PERIOD s.
        TimeoutError after ``timeout`` seconds.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        watched = 0.0
        told = time.monotonic()
        while not run.done():
            now = time.monotonic()
            if deadline is not None and now > deadline:
                raise TimeoutError(f"coordinator run not done after {timeout} s")
            if on_progress is not None and now - told > PROGRESS_PERIOD:
                on_progress(self._coordinator.progress())
                told = now
            if step is not None:
                step()
            # The other processes' reports (a failure) need no more than a few looks a
            # second; a look polls a pipe, and a spin can take just microseconds.
            if now - watched > 0.25:
                self._drain()
                watched = now
            self._host.spin_once(0.02)
        return run.result()

    def discover(
        self,
        policy: str,
        timeout: float | None = None,
        on_progress: Callable[[str], None] | None = None,
        estimator: str = PATH,
        per_run: int | None = None,
    ) -> DiscoveryResult:
        """Run discovery for every FLS and blind neighbour; sources estimate by ``estimator``.

        The sources search in runs of ``per_run`` at most (default: as many as
        the labels' memory allows, ``protocol.runs.sources_per_run``); the
        result is theirs together.
        """
        coordinator = self._coordinator
        blocks = self.source_blocks(per_run)
        deadline = None if timeout is None else time.monotonic() + timeout
        results: list[DiscoveryResult] = []
        for number, block in enumerate(blocks, 1):
            sources = list(block) if len(blocks) > 1 else None
            told = on_progress
            if on_progress is not None and len(blocks) > 1:
                told = _block_progress(on_progress, number, len(blocks))
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            run = coordinator.discover(policy, sources, estimator=estimator)
            results.append(self.run(run, left, on_progress=told))
        return merged(results)

    def source_blocks(self, per_run: int | None = None) -> list[tuple[int, ...]]:
        """The live FLSs in the blocks that :meth:`discover` runs one after the other."""
        coordinator = self._coordinator
        live = coordinator.fls_ids - coordinator.departed
        return source_blocks(live, per_run or sources_per_run(len(coordinator.fls_ids)))

    def make_moves(
        self,
        plain: Evaluation,
        technique: str = "move-obstructing",
        threshold: int = 10,
        timeout: float | None = None,
        on_progress: Callable[[str], None] | None = None,
    ) -> MoveResult:
        """A heuristic on the BLOCKED pairs of a whole-swarm run (``plain``, the evaluation of
        its estimates), its moves made by the swarm."""
        moves = self._coordinator.make_moves(plain, technique, threshold)
        result: MoveResult = self.run(moves, timeout, on_progress=on_progress)
        return result

    def spin(self, seconds: float | None = None) -> None:
        """Serve the swarm for ``seconds`` (for ever when None), watching the processes."""
        deadline = None if seconds is None else time.monotonic() + seconds
        while deadline is None or time.monotonic() < deadline:
            self._drain()
            self._host.spin_for(0.1)

    def close(self) -> None:
        """Stop every process and destroy every node; Ctrl-C waits until this is done."""
        stopping = {signal.SIGINT, signal.SIGTERM}
        signal.pthread_sigmask(signal.SIG_BLOCK, stopping)
        try:
            self._close()
        finally:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, stopping)

    def _close(self) -> None:
        self.coordinator = None  # its host destroys it
        if self.recorder is not None:
            self.recorder.close()
        self._stop.set()
        if self.fls_processes is not None:
            self.ended = self.fls_processes.stop()
        self.discovery_servers.stop()
        for child in self._children:
            if child.pid is not None:
                child.join(timeout=30)
                if child.is_alive():
                    child.terminate()
                    child.join(timeout=5)
        if self.host is not None and not self._leave_nodes:
            self.host.close()
            self.host = None
        if self.context is not None and not self._leave_nodes:
            self.context.try_shutdown()
            self.context = None


def _block_progress(
    tell: Callable[[str], None], number: int, blocks: int
) -> Callable[[str], None]:
    """``tell``, with which block of sources the run is on."""
    return lambda progress: tell(f"sources block {number}/{blocks}: {progress}")


def first_scene(world: World, view: ViewConfig) -> Scene:
    """The scene a view shows when the swarm comes up."""
    name = world.cloud.name
    if view.colour_by == "status" or view.pairs:
        # The engine's evaluation: the swarm's discovery finds the same, pair for pair.
        evaluation = evaluate(world.swarm, world.sensor, view.policy)
        title = f"{name}: each FLS's share of blind neighbours with a sweet path"
        if view.colour_by == "status":
            return evaluation_scene(evaluation, title, pairs=view.pairs)
        scene = evaluation_scene(evaluation, name, "ranges", view.seen_from, pairs=view.pairs)
    else:
        scene = ranges_scene(world.hood, f"{name}: range classes", view.seen_from)
    return replace(
        scene, title=f"{name}: range classes seen from FLS {scene.ids[scene.highlight]}"
    )
