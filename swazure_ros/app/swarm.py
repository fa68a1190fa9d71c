"""Running a swarm: bring it up over one or more processes, and compute with it.

The launcher's process hosts the world node and the first share of FLS nodes;
the other FLSs run in further processes, packed in shares or one per FLS
(:mod:`.processes`). Every process builds the same world from one
:class:`WorldSpec`, so none needs the others' data, and lays out what its own
share senses (the race car's whole swarm's observations are 650 MB). The
swarm is up when every process sees every FLS node's endpoints.

:meth:`RunningSwarm.discover` and :meth:`RunningSwarm.make_moves` run the
coordinator's protocols over the swarm (:mod:`.compute` sets a whole swarm's
run beside the engine's).
"""

from __future__ import annotations

import os
import shutil
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
from ..files.record import BringUp
from ..protocol.runs import DiscoveryResult, MoveResult, merged, source_blocks, sources_per_run
from ..ros.nodes.coordinator import Coordinator, Future
from ..ros.nodes.view import ViewNode
from ..ros.nodes.world_node import SimulatedCameras
from ..ros.plumbing.runtime import Context
from ..ros.programs.host import SwarmHost
from ..ros.recording.bag import Recorder
from ..ros.security.auth import SwarmKey, new_key
from ..sim.world import World
from ..view.scene import Scene, evaluation_scene, ranges_scene
from .config import SwarmConfig, ViewConfig
from .discovery_server import DiscoveryServers
from .per_fls import Ended
from .processes import PackedShares, ProcessPerFls, SwarmProcesses
from .share import (
    announced_instance,
    host_config,
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
    every node. A log folder made here (no ``config.log_dir``) is removed when
    the swarm is left without an error (Ctrl-C included) and every FLS process
    ended with code 0; else it stays, for its logs to be read.
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
        #: Up and discovered (wait_until_ready).
        self.ready = False
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
        own_shares = shares(assigned, parts)
        if config.hosts > 1:
            # Only this host's share here; the others run on their own hosts.
            own_shares = [own_shares[config.share]]
        self.key = SwarmKey(*_swarm_key(config))
        # A folder for the logs of the processes started here, if any are.
        started = config.per_fls or bool(config.discovery_servers)
        log_dir = Path(config.log_dir or (tempfile.mkdtemp(prefix="swazure-") if started else "."))
        #: The log folder, if made here: removed once the swarm has ended well (__exit__).
        self.temporary_logs = log_dir if started and config.log_dir is None else None
        self.discovery_servers = DiscoveryServers(config.discovery_servers, log_dir)
        self.processes: SwarmProcesses
        if config.per_fls:
            # This host's FLS processes; share 0 also simulates every FLS's camera.
            self.processes = ProcessPerFls(
                config, self.key, own_shares[0], self.size, log_dir, on_lost or _ignore
            )
        else:
            self.processes = PackedShares(config, self.key, own_shares)
        # Each process lays out what its own FLSs sense; the coordinator's
        # planning and the engine's comparison need the neighbourhood, not that.
        self.world = config.world.build(hosted_ids=self.processes.laid_out)
        self._own_created = 0
        self.context: Context | None = None
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

    def __exit__(self, kind: type[BaseException] | None, *exc_info: object) -> None:
        self.close()
        # Ctrl-C (KeyboardInterrupt) is how a served swarm ends: not an error.
        if kind is None or issubclass(kind, KeyboardInterrupt):
            self._discard_logs()

    def _discard_logs(self) -> None:
        """Remove the log folder made here, unless an FLS process ended unclean."""
        ended = self.processes.ended if isinstance(self.processes, ProcessPerFls) else []
        if self.temporary_logs is not None and all(one.code == 0 for one in ended):
            shutil.rmtree(self.temporary_logs, ignore_errors=True)
            self.temporary_logs = None

    def _start(self) -> None:
        self.discovery_servers.start()
        self.processes.start()
        self.context = init_context(self.config)
        leader = self.config.share == 0
        own = host_config(
            self.config, self.processes.own_share, self.config.share, self.size, self.key, leader
        )
        self.host = SwarmHost(self.world, own, context=self.context)

        def created(count: int) -> None:
            self._own_created = count
            self._watch()
            self._tell_created()

        if leader and self.config.record is not None:
            # Before the nodes: it hears every topic from its first publisher on.
            self.recorder = Recorder(
                Path(self.config.record), self.config.namespace, context=self.context
            )
            self.host.add(self.recorder)
        self.host.create_fls_nodes(created)
        if self.processes.simulates_cameras and leader:
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
                hosts=self.processes.radios,
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
        return [os.getpid(), *self.processes.process_ids()]

    def _watch(self) -> None:
        """Take the other processes' news; SwazureError for one that failed."""
        self.processes.watch(self.ready)

    def _tell_created(self) -> None:
        """Tell ``on_created`` how many FLS nodes are up, while the swarm comes up."""
        if self.host is not None and not self.ready:
            self._on_created(self.processes.created(self._own_created, self.host), self.size)

    def wait_until_ready(self) -> BringUp:
        """Spin until every process has discovered the whole swarm; return the bring-up."""
        deadline = time.monotonic() + self.config.discovery_timeout
        discovered = False
        while time.monotonic() < deadline:
            self._watch()
            self._tell_created()
            if not discovered:
                discovered = self._host.is_discovered()
            # Seeing every node is not enough: a host whose radio has not matched the
            # coordinator's controls yet would miss a run's START (shares on other hosts).
            matched = self.coordinator is None or self.coordinator.hosts_matched()
            # A recording starts with everything the run publishes.
            matched = matched and (self.recorder is None or self.recorder.caught_up())
            if discovered and matched and self.processes.ready():
                seconds = time.perf_counter() - self._began
                peaks = [peak_rss_mb(), *self.processes.peak_rss_mb()]
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
                self._watch()
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
        live = coordinator.fls_ids - coordinator.departed_next()
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
            self._watch()
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
        self.processes.stop()
        self.discovery_servers.stop()
        if self.host is not None and not self._leave_nodes:
            self.host.close()
            self.host = None
        if self.context is not None and not self._leave_nodes:
            self.context.try_shutdown()
            self.context = None


def _swarm_key(config: SwarmConfig) -> tuple[bytes | None, bytes | None]:
    """The swarm's secret (None: unsigned) and instance (None: a fresh one, this swarm's life)."""
    key = config.key if config.authenticate else None
    if key is None and config.authenticate and config.hosts == 1:
        key = new_key()
    instance = None
    if key is not None and config.share != 0:
        # A further host of a swarm that shares a key file: the world node's.
        instance = announced_instance(config, key)
    return key, instance


def _ignore(ended: Ended) -> None:
    """No one to tell of an FLS lost."""


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
