"""Running a swarm: bring it up over one or more processes, and compute with it.

The launcher's process hosts the world node and the first share of FLS nodes;
the other FLSs run in further processes, packed in shares or one per FLS
(:mod:`.processes`). Every process builds the same world from one
:class:`WorldSpec`, so none needs the others' data, and lays out what its own
share senses (the race car's whole swarm's observations are 650 MB). The
swarm is up when every process sees every FLS node's endpoints.

:meth:`RunningSwarm.start` brings a swarm up and gives it back running;
:meth:`RunningSwarm.discover` and :meth:`RunningSwarm.make_moves` run the
coordinator's protocols over it (:mod:`.compute` sets a whole swarm's run
beside the engine's).
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..core.errors import RunError, SwazureError
from ..core.evaluate import evaluate
from ..core.evaluation import Evaluation
from ..core.fit import LOCAL_LEAST_SQUARES, PATH
from ..files.record import BringUp
from ..protocol.runs import (
    DiscoveryResult,
    MoveResult,
    merged,
    next_block,
    next_block_size,
    sources_per_run,
    swarm_label_memory,
)
from ..ros.nodes.coordinator import Coordinator, Future
from ..ros.nodes.view import ViewNode
from ..ros.nodes.world_node import SimulatedCameras
from ..ros.plumbing.process import Context
from ..ros.programs.host import HostConfig, SwarmHost
from ..ros.recording.recorder import Recorder
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


@dataclass(frozen=True)
class _Plan:
    """A swarm about to start: its key, processes and log folder; nothing runs yet, and no
    world is built (each process builds its own once started: :meth:`RunningSwarm.start`)."""

    config: SwarmConfig
    size: int  # FLSs
    key: SwarmKey
    processes: SwarmProcesses
    discovery_servers: DiscoveryServers
    temporary_logs: Path | None  # the log folder, if made here: removed once ended well


@dataclass(frozen=True)
class Starting:
    """A swarm while it comes up, for the one who starts it (:meth:`RunningSwarm.start`):
    this process's host (a signal handler stops between its spins), the world, the
    processes and the recording: what a failed bring-up is measured by, and what is
    reported once the swarm has stopped."""

    world: World
    processes: SwarmProcesses  # once stopped, how one FLS's processes ended (ProcessPerFls)
    discovery_servers: DiscoveryServers
    context: Context
    host: SwarmHost
    recorder: Recorder | None  # the leader's, when the swarm is recorded; closed once stopped


class RunningSwarm:
    """A running swarm, up and discovered: the launcher's own share and the further processes.

    :meth:`start` brings one up. It is a context manager; leaving it (or
    :meth:`close`) stops every process and destroys every node. A log folder
    made here (no ``config.log_dir``) is removed when the swarm is left
    without an error (Ctrl-C included) and every FLS process ended with code
    0; else it stays, for its logs to be read.
    """

    def __init__(
        self,
        plan: _Plan,
        starting: Starting,
        coordinator: Coordinator | None,
        view: ViewNode | None,
        bring_up: BringUp,
        leave_nodes: bool,
    ) -> None:
        self.config = plan.config
        self.size = plan.size
        self.key = plan.key
        #: Each process lays out what its own FLSs sense; the view and the swarm's heuristics
        #: need the whole neighbourhood, which this world holds where ``config.whole_world``
        #: says so.
        self.world = starting.world
        self.processes = plan.processes
        self.discovery_servers = plan.discovery_servers
        self.context = starting.context
        self.host = starting.host
        #: None on a further host of a swarm over several (share > 0): share 0 runs it.
        self.coordinator = coordinator
        self.recorder = starting.recorder  # the leader's, when the swarm is recorded
        self.view = view  # the leader's, when the swarm is shown
        self.bring_up = bring_up  # launcher start to every process discovered
        self._plan, self._leave_nodes = plan, leave_nodes
        self._closed = False

    @classmethod
    def start(
        cls,
        config: SwarmConfig,
        on_created: Callable[[int, int], None] | None = None,
        *,
        leave_nodes: bool = False,
        on_lost: Callable[[Ended], None] | None = None,
        on_starting: Callable[[Starting], None] | None = None,
        on_failed: Callable[[Starting, Exception], None] | None = None,
    ) -> RunningSwarm:
        """Bring the swarm ``config`` describes up; return it once every process has
        discovered the whole swarm.

        ``on_created(created, total)`` hears how many FLS nodes are up across every
        process while it comes up; ``on_lost`` hears of an FLS process that ends
        while the swarm runs. ``on_starting`` gets the swarm as it comes up
        (:class:`Starting`) once this process's host is made, before its nodes;
        ``on_failed`` gets it with the error when the bring-up then fails, before
        anything is stopped. With ``leave_nodes``, stopping leaves this process's
        nodes to its end (``process.exit_process``: far faster than destroying
        them one by one). SwazureError for a swarm that cannot be split as asked,
        RunError for one not discovered in ``config.discovery_timeout`` s or a
        process that failed.
        """
        began = time.perf_counter()
        plan = _plan(config, on_lost or _ignore)
        context = host = recorder = starting = None
        try:
            plan.discovery_servers.start()
            plan.processes.start()
            # Built while the further processes build theirs, each from the same spec: on
            # torus:10000 over 2 the further process started 27 s later, after this world.
            world = config.world.build(
                hosted_ids=plan.processes.laid_out,
                only_hosted_pairs=not config.whole_world,
                pairs_on_demand=not config.whole_world,
                decaying_on_demand=not config.whole_world,
            )
            context = init_context(config)
            host = SwarmHost(world, _own_config(plan), context=context)
            recorder = _recorder(plan, context, host)
            starting = Starting(
                world, plan.processes, plan.discovery_servers, context, host, recorder
            )
            if on_starting is not None:
                on_starting(starting)
            progress = _Creation(plan, host, on_created)
            coordinator, view = _create_nodes(plan, starting, progress)
            bring_up = _wait_until_ready(plan, starting, coordinator, progress, began)
        except BaseException as err:
            try:
                if isinstance(err, Exception) and starting is not None and on_failed is not None:
                    on_failed(starting, err)
            finally:
                # What came up stops, also when the one told of the failure fails.
                _stop(plan, context, host, recorder, leave_nodes)
                if isinstance(err, KeyboardInterrupt):
                    _discard_logs(plan)
            raise
        return cls(plan, starting, coordinator, view, bring_up, leave_nodes)

    def __enter__(self) -> RunningSwarm:
        return self

    def __exit__(self, kind: type[BaseException] | None, *exc_info: object) -> None:
        self.close()
        # Ctrl-C (KeyboardInterrupt) is how a served swarm ends: not an error.
        if kind is None or issubclass(kind, KeyboardInterrupt):
            _discard_logs(self._plan)

    @property
    def process_ids(self) -> list[int]:
        """The pids of this swarm's packed processes: this one, then each further share's."""
        return [os.getpid(), *self.processes.process_ids()]

    def _watch(self) -> None:
        """Take the other processes' news; SwazureError for one that failed."""
        self.processes.watch(True)

    @property
    def _coordinator(self) -> Coordinator:
        if self.coordinator is None:
            raise SwazureError(
                f"share {self.config.share} of a swarm over {self.config.hosts} hosts runs "
                "no coordinator: share 0 runs it"
            )
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
            self.host.spin_once(0.02)
        return run.result()

    def discover(
        self,
        policy: str,
        timeout: float | None = None,
        on_progress: Callable[[str], None] | None = None,
        estimator: str = PATH,
        per_run: int | None = None,
        label_memory: int | None = None,
    ) -> DiscoveryResult:
        """Run discovery for every FLS and blind neighbour; sources estimate by ``estimator``.

        The sources search in runs of ``per_run`` at most; by default, the
        first run's as many as ``label_memory`` (bytes; by default
        :attr:`label_memory`) allows were every FLS to hold every source's
        label (:meth:`first_block`), and each later run's as many as the memory
        the run before took allows (``protocol.runs.next_block_size``). The
        result is theirs together.
        """
        coordinator = self._coordinator
        memory = self.label_memory if label_memory is None else label_memory
        first, left_ids = self.first_block(per_run, memory, estimator)
        size, whole = len(first), len(left_ids)
        deadline = None if timeout is None else time.monotonic() + timeout
        results: list[DiscoveryResult] = []
        while left_ids or not results:
            block, rest = next_block(left_ids, size) if left_ids else ((), ())
            alone = not results and len(block) == whole
            told = on_progress
            if on_progress is not None and not alone:
                told = _block_progress(on_progress, len(results) + 1, whole - len(left_ids), whole)
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            run = coordinator.discover(policy, None if alone else list(block), estimator=estimator)
            results.append(self.run(run, left, on_progress=told))
            left_ids = rest
            if per_run is None:
                size = next_block_size(len(block), results[-1].outcome.label_bytes, memory)
        return merged(results)

    def first_block(
        self, per_run: int | None = None, label_memory: int | None = None, estimator: str = PATH
    ) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """(the sources of :meth:`discover`'s first run, every live FLS's id), ascending."""
        coordinator = self._coordinator
        live = tuple(sorted(coordinator.fls_ids - coordinator.departed_next()))
        # A run whose sources estimate by local least squares sums fits in its labels too.
        fits = estimator == LOCAL_LEAST_SQUARES
        memory = self.label_memory if label_memory is None else label_memory
        size = per_run or sources_per_run(len(coordinator.fls_ids), memory, fits)
        return (next_block(live, size)[0] if live else ()), live

    @property
    def label_memory(self) -> int:
        """The labels a whole-swarm discovery keeps at once by default, bytes, all shares
        together (``protocol.runs.swarm_label_memory``)."""
        return swarm_label_memory(max(self.config.processes, self.config.hosts))

    def make_moves(
        self,
        plain: Evaluation,
        technique: str = "move-obstructing",
        threshold: int = 10,
        timeout: float | None = None,
        on_progress: Callable[[str], None] | None = None,
        source_body: bool = False,
    ) -> MoveResult:
        """A heuristic on the BLOCKED pairs of a whole-swarm run (``plain``, the evaluation of
        its estimates), its moves made by the swarm (``source_body``: Move Source planned
        with the source's body at its probe point checked)."""
        moves = self._coordinator.make_moves(plain, technique, threshold, source_body)
        result: MoveResult = self.run(moves, timeout, on_progress=on_progress)
        return result

    def spin(self, seconds: float | None = None) -> None:
        """Serve the swarm for ``seconds`` (for ever when None), watching the processes."""
        deadline = None if seconds is None else time.monotonic() + seconds
        while deadline is None or time.monotonic() < deadline:
            self._watch()
            self.host.spin_for(0.1)

    def close(self) -> None:
        """Stop every process and destroy every node; Ctrl-C waits until this is done.
        Closing again does nothing."""
        if self._closed:
            return
        self._closed = True
        _stop(self._plan, self.context, self.host, self.recorder, self._leave_nodes)


def _plan(config: SwarmConfig, on_lost: Callable[[Ended], None]) -> _Plan:
    """What starting the swarm ``config`` describes takes; SwazureError when it cannot be
    split as asked."""
    assigned = config.world.assigned()
    fls_ids = assigned.cloud_index
    size = len(fls_ids)
    parts = max(config.processes, config.hosts)
    if parts > size:
        raise SwazureError(f"{parts} shares for {size} FLSs: too many")
    strangers = sorted(set(config.fls_parameters) - set(fls_ids.tolist()))
    if strangers:
        raise SwazureError(
            f"parameters for FLS {strangers[0]}: no such FLS in this swarm of {size} "
            f"(ids {fls_ids[0]}..{fls_ids[-1]})"
        )
    own_shares = shares(assigned, parts)
    if config.hosts > 1:
        # Only this host's share here; the others run on their own hosts.
        own_shares = [own_shares[config.share]]
    key = SwarmKey(*_swarm_key(config))
    # A folder for the logs of the processes started here, if any are.
    started = config.per_fls or bool(config.discovery_servers)
    log_dir = Path(config.log_dir or (tempfile.mkdtemp(prefix="swazure-") if started else "."))
    processes: SwarmProcesses
    if config.per_fls:
        # This host's FLS processes; share 0 also simulates every FLS's camera.
        processes = ProcessPerFls(config, key, own_shares[0], size, log_dir, on_lost)
    else:
        processes = PackedShares(config, key, own_shares)
    return _Plan(
        config,
        size,
        key,
        processes,
        DiscoveryServers(config.discovery_servers, log_dir),
        log_dir if started and config.log_dir is None else None,
    )


def _own_config(plan: _Plan) -> HostConfig:
    """What this process hosts: its share of FLSs, and the world node on the leader."""
    config = plan.config
    own = plan.processes.own_share
    return host_config(config, own, config.share, plan.size, plan.key, config.share == 0)


def _recorder(plan: _Plan, context: Context, host: SwarmHost) -> Recorder | None:
    """The leader's recorder of every topic, when the swarm is recorded; made before the
    nodes, it hears every topic from its first publisher on."""
    config = plan.config
    if config.share != 0 or config.record is None:
        return None
    recorder = Recorder(Path(config.record), config.namespace, context=context)
    host.add(recorder)
    return recorder


class _Creation:
    """Tells ``on_created`` how many FLS nodes are up across every process, while the swarm
    comes up."""

    def __init__(
        self, plan: _Plan, host: SwarmHost, on_created: Callable[[int, int], None] | None
    ) -> None:
        self._plan, self._host = plan, host
        self._on_created = on_created or (lambda created, total: None)
        self._own = 0  # FLS nodes created in this process

    def created(self, count: int) -> None:
        """``count`` FLS nodes of this process are up."""
        self._own = count
        self._plan.processes.watch(False)
        self.tell()

    def tell(self) -> None:
        """Tell how many FLS nodes are up in every process."""
        self._on_created(self._plan.processes.created(self._own, self._host), self._plan.size)


def _create_nodes(
    plan: _Plan, starting: Starting, progress: _Creation
) -> tuple[Coordinator | None, ViewNode | None]:
    """Create this process's FLS nodes and, on the leader (share 0), the simulated cameras
    where no FLS process renders its own, the coordinator and the view (when shown)."""
    config, world, context, host = plan.config, starting.world, starting.context, starting.host
    leader = config.share == 0
    host.create_fls_nodes(progress.created)
    if plan.processes.simulates_cameras and leader:
        cameras = SimulatedCameras(
            host.replica,
            world.ids.tolist(),
            namespace=config.namespace,
            context=context,
            key=plan.key,
        )
        host.add(cameras)
    if not leader:
        return None, None
    coordinator = Coordinator(
        world.ids.tolist(),
        hosts=plan.processes.radios,
        shape=world.swarm,
        sensor=world.sensor,
        namespace=config.namespace,
        context=context,
        key=plan.key,
        # One node: ros2 param reaches it in every mode, at six services' cost.
        parameter_services=True,
    )
    host.add(coordinator)
    view = None
    if config.view is not None:
        view = ViewNode(
            first_scene(world, config.view),
            namespace=config.namespace,
            context=context,
            port=config.view.port,
            key=plan.key,
        )
        host.add(view)
    return coordinator, view


def _wait_until_ready(
    plan: _Plan,
    starting: Starting,
    coordinator: Coordinator | None,
    progress: _Creation,
    began: float,
) -> BringUp:
    """Spin until every process has discovered the whole swarm; the bring-up since
    ``began`` (perf_counter). RunError after ``config.discovery_timeout`` s."""
    config, host, recorder = plan.config, starting.host, starting.recorder
    deadline = time.monotonic() + config.discovery_timeout
    discovered = False
    while time.monotonic() < deadline:
        plan.processes.watch(False)
        progress.tell()
        if not discovered:
            discovered = host.is_discovered()
        # Seeing every node is not enough: a host whose radio has not matched the
        # coordinator's controls yet would miss a run's START (shares on other hosts).
        matched = coordinator is None or coordinator.hosts_matched()
        # A recording starts with everything the run publishes.
        matched = matched and (recorder is None or recorder.caught_up())
        if discovered and matched and plan.processes.ready():
            seconds = time.perf_counter() - began
            peaks = [peak_rss_mb(), *plan.processes.peak_rss_mb()]
            return BringUp(plan.size, len(peaks), seconds, peaks)
        host.spin_for(0.05)
    raise RunError(
        f"swarm not discovered after {config.discovery_timeout:g} s: "
        f"{host.discovery_text()} visible" + unreached_text(host.unreached())
    )


def _stop(
    plan: _Plan,
    context: Context | None,
    host: SwarmHost | None,
    recorder: Recorder | None,
    leave_nodes: bool,
) -> None:
    """Stop every process and destroy every node made so far (None: not made);
    Ctrl-C waits until this is done."""
    stopping = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stopping)
    try:
        if recorder is not None:
            recorder.close()
        plan.processes.stop()
        plan.discovery_servers.stop()
        if leave_nodes:
            return
        if host is not None:
            host.close()  # the coordinator and the view with it
        if context is not None:
            context.try_shutdown()
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, stopping)


def _discard_logs(plan: _Plan) -> None:
    """Remove the log folder made here, unless an FLS process ended unclean."""
    processes = plan.processes
    ended = processes.ended if isinstance(processes, ProcessPerFls) else []
    if plan.temporary_logs is not None and all(one.code == 0 for one in ended):
        shutil.rmtree(plan.temporary_logs, ignore_errors=True)


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
    tell: Callable[[str], None], number: int, searched: int, sources: int
) -> Callable[[str], None]:
    """``tell``, with which block of sources the run is on and how many searched before it."""
    done = f"{searched:,} of {sources:,} sources searched"
    return lambda progress: tell(f"sources block {number} ({done}): {progress}")


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
