"""A track run over ROS 2: a source FLS follows a moving target through a relay.

:class:`TrackSession` hosts the FLS nodes around a source in this process,
drives their clock (``/clock``, the nodes run with ``use_sim_time``) and
collects the source's TrackEstimate messages; :func:`run_track` runs one track
from start to end. The simulated clock advances one frame at a time, and
only once the estimates due by then have arrived, so a run takes as long as
the machine needs and gives the same numbers every time, the same as the
protocol's in-memory :func:`~swazure_ros.protocol.loops.simulate_track`:
both drive the same relay and source machines.
"""

from __future__ import annotations

import tempfile
import time
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.frames import to_metres
from ..core.motion import Motion
from ..core.tracking import TRACK_SETTINGS, TrackConfig, TrackRun, arrival, nanoseconds
from ..files.description import SwarmDescription
from ..ros.clients.track_client import SwarmStalledError, TrackClient
from ..ros.nodes.clock import SimClock
from ..ros.nodes.world_node import SimulatedCameras
from ..ros.plumbing.process import Context, init_context
from ..ros.programs.host import HostConfig, SwarmHost
from ..ros.security.auth import SwarmKey
from ..sim.world import World
from .per_fls import FlsProcesses

#: Wall seconds the swarm may go without progress in one step of a session (its
#: discovery, a track's start, a frame of the simulated clock) before it counts as
#: stalled. A step takes milliseconds; an FLS process of its own on a busy 2-core machine
#: has taken over 10 s, and two test suites side by side stretch that further. Any news
#: (a reader matched, a report, a message counted) starts the wait afresh
#: (:meth:`TrackSession.progress`): a slow swarm is not a stalled one.
ANSWER_TIMEOUT = 120.0


def track_parameters(config: TrackConfig) -> dict[str, object]:
    """The FLS node parameters of ``config``, on the simulated clock."""
    parameters: dict[str, object] = {
        f"track.{name}": getattr(config, name) for name in TRACK_SETTINGS
    }
    parameters["track.service"] = True
    parameters["use_sim_time"] = True
    return parameters


@dataclass(frozen=True)
class PerFls:
    """A track run whose FLSs run one to a process: their swarm's description and motion.

    ``motion`` is the run's :class:`~swazure_ros.core.motion.Motion` as text
    (``FLS=TRAJECTORY;...``, :func:`~swazure_ros.files.trajectories.parse_motion`):
    each FLS process builds its simulated relay camera of it.
    """

    description: SwarmDescription
    motion: str
    log_dir: Path | None = None
    key: bytes | None = None


class TrackSession:
    """FLS nodes on a simulated clock, and a client that tracks.

    The nodes run in this process, or, with ``per_fls``, each in a process of
    its own (:class:`~swazure_ros.app.per_fls.FlsProcesses`) beside this
    process's simulated cameras; they then report their part in the run on
    ``track_progress``, by which this session knows when all is delivered.
    """

    def __init__(
        self,
        world: World,
        motion: Motion,
        fls_ids: Sequence[int],
        config: TrackConfig,
        *,
        context: Context,
        namespace: str = "swarm",
        per_fls: PerFls | None = None,
    ) -> None:
        self.config = config
        self.namespace = namespace.strip("/")
        self.fls_ids = [int(fls_id) for fls_id in fls_ids]
        self.processes: FlsProcesses | None = None
        key = SwarmKey(per_fls.key if per_fls is not None else None)
        if per_fls is not None:
            self.processes = FlsProcesses(
                per_fls.description,
                self.fls_ids,
                per_fls.log_dir or Path(tempfile.mkdtemp(prefix="swazure-track-")),
                namespace=self.namespace,
                key=key,
                domain_id=context.get_domain_id(),
                parameters={
                    **track_parameters(config),
                    "track.motion": per_fls.motion,
                    "track.report_progress": True,
                    "track.peers": len(self.fls_ids),
                },
            )
        own = HostConfig(
            fls_ids=() if per_fls is not None else tuple(self.fls_ids),
            namespace=self.namespace,
            swarm_size=len(self.fls_ids),
            with_world_node=False,
            parameters=track_parameters(config),
            key=key,
        )
        self.host = SwarmHost(world, own, context=context, motion=motion)
        if per_fls is not None:
            # What the FLSs' cameras see, so that each joins the swarm's radio.
            self.host.add(
                SimulatedCameras(
                    self.host.replica,
                    self.fls_ids,
                    namespace=self.namespace,
                    context=context,
                    key=key,
                )
            )
        self.clock = SimClock(context=context)
        self.host.add(self.clock)
        self.client = TrackClient(
            namespace=self.namespace,
            context=context,
            ids=self.host.replica.world.ids,
            guard=self.host.guard if per_fls is not None else None,
        )
        self.host.add(self.client)
        # What stopped nodes sent and heard: their messages still count as delivered.
        self._departed_traffic: Counter[str] = Counter()

    def start(self, discovery_timeout: float = 60.0) -> None:
        """Create the FLS nodes at simulated time 0 and wait until they are discovered, for
        as long as discovery makes progress and ``discovery_timeout`` s past the last."""
        self.clock.set(0)
        self.host.create_fls_nodes()
        if self.processes is not None:
            self.processes.start()
        if not self.spin_until(self._ready, discovery_timeout, self.progress):
            raise SwarmStalledError(
                f"the FLS nodes were not discovered: no progress in {discovery_timeout} s"
            )

    def progress(self) -> tuple[int, ...]:
        """Counts that only grow while the swarm comes up and works: a change is progress.

        The FLS processes' endpoints this session sees, the progress reports
        and estimates it heard, and the track messages of the FLS nodes in
        this process.
        """
        own = sum(sum(node.tracking.traffic.values()) for node in self.host.fls_nodes)
        heard = (self.client.reports_heard, len(self.client.estimate_messages), own)
        return (*self.client.matched(), *heard, len(self.host.fls_nodes))

    def _check_processes(self) -> None:
        """SwarmStalledError when an FLS process has ended."""
        if self.processes is not None and (ended := self.processes.ended()):
            log = self.processes.log(ended[0].fls_id)
            raise SwarmStalledError(f"{ended[0].describe()} (log: {log})")

    def _ready(self) -> bool:
        self._check_processes()
        if not self.host.is_discovered():
            return False
        if self.processes is None:
            return True
        # Each FLS's radio is up (at its camera's first frame), its track publishers are
        # matched here, and it has reported: it reports first once its requests and
        # samples reach every other FLS's radio (track.peers), so nothing it sends is lost.
        count = len(self.fls_ids)
        return self.client.hears(count) and len(self.client.progress) >= count

    def track(self, source: int, target: int, model: str, timeout: float = ANSWER_TIMEOUT) -> int:
        """Ask FLS ``source`` to track ``target``; return the relay, or raise TrackingError."""
        relay = self.client.track(source, target, model, self.spin_until, timeout)
        if not self.spin_until(self.delivered, timeout, self.progress):
            raise SwarmStalledError(f"relay FLS {relay} did not start: no progress in {timeout} s")
        return relay

    def advance(self, nanoseconds: int, timeout: float = ANSWER_TIMEOUT) -> None:
        """Set the clock to ``nanoseconds`` and spin until everything due is :meth:`delivered`."""
        self.clock.set(nanoseconds)
        republish = time.monotonic() + 0.1

        def delivered() -> bool:
            self._check_processes()
            nonlocal republish
            if time.monotonic() > republish:
                # /clock is best effort: a lost tick would leave a node behind for ever.
                self.clock.set(nanoseconds)
                republish = time.monotonic() + 0.1
            return self.delivered()

        if not self.spin_until(delivered, timeout, self.progress):
            raise SwarmStalledError(
                f"the swarm did not answer: no progress in {timeout} s of wall time at "
                f"simulated {nanoseconds / 1e9:.3f} s"
            )

    def delivered(self) -> bool:
        """True when every track message due by now in this process has been sent and heard.

        Due: every FLS node's clock at the session's time; each relay's frames
        up to now sensed and its samples whose delay has passed published; then
        every request and sample heard and every estimate received by this
        session's client.
        """
        now = self.clock.nanoseconds
        traffic = Counter(self._departed_traffic)
        for node in self.host.fls_nodes:
            if node.get_clock().now().nanoseconds < now:
                return False  # its relay frames and timeouts for this tick have not run
            traffic.update(node.tracking.traffic)
            if node.tracking.relay.due(now):
                return False
        # FLSs in processes of their own, as they last reported: one that never
        # reported has neither tracked nor relayed yet.
        for report in self.client.progress.values():
            if report.time < now or report.due:
                return False
            traffic.update(report.traffic)
        return (
            traffic["requests_sent"] == traffic["requests_heard"]
            and traffic["samples_sent"] == traffic["samples_heard"]
            and traffic["estimates_sent"] == len(self.client.estimate_messages)
        )

    def stop_fls(self, fls_id: int) -> None:
        """Stop FLS ``fls_id``'s node, as if its software stopped (see SwarmHost.stop_fls)."""
        self._departed_traffic.update(self.host.fls_by_id[fls_id].tracking.traffic)
        self.host.stop_fls(fls_id)

    def spin_until(
        self,
        condition: Callable[[], bool],
        timeout: float,
        progress: Callable[[], object] | None = None,
    ) -> bool:
        """Spin until ``condition()``; return whether it holds.

        It gives up after ``timeout`` wall s in all, or, with ``progress``,
        after ``timeout`` wall s in which ``progress()`` did not change.
        """
        deadline = time.monotonic() + timeout
        mark = None if progress is None else progress()
        while not condition():
            if progress is not None and (now := progress()) != mark:
                mark, deadline = now, time.monotonic() + timeout
            if time.monotonic() > deadline:
                return False
            self.host.spin_once(0.01)
        return True

    def close(self) -> None:
        """Destroy every node, and stop every FLS process."""
        if self.processes is not None:
            self.processes.stop()
        self.host.close()


def taking_part(world: World, source: int, target: int) -> list[int]:
    """The FLSs that can take part in a track: source, target, and the source's sweet neighbours.

    A relay is one of the sweet neighbours; the other FLSs would only idle.
    """
    return sorted({source, target, *world.neighbours(source).sweet.tolist()})


def run_track(
    world: World,
    motion: Motion,
    source: int,
    target: int,
    config: TrackConfig,
    duration: float,
    *,
    domain_id: int | None = None,
    namespace: str = "swarm",
    on_progress: Callable[[float], None] | None = None,
    per_fls: PerFls | None = None,
) -> TrackRun:
    """Track ``target`` from ``source`` for ``duration`` simulated s over ROS 2; see the module.

    With ``per_fls``, each FLS taking part runs in a process of its own.
    """
    config.frames(duration)  # bounded before any work
    world.index(source), world.index(target)  # unknown ids fail before any node starts
    context = init_context(domain_id)
    session = TrackSession(
        world,
        motion,
        taking_part(world, source, target),
        config,
        context=context,
        namespace=namespace,
        per_fls=per_fls,
    )
    try:
        session.start()
        relay = session.track(source, target, config.model)
        step = nanoseconds(config.frame_period)
        # The relays release samples at their frame ticks: the last one due is on a tick.
        horizon = nanoseconds(arrival(duration, config))
        last = -(-horizon // step) * step
        for now in range(0, last + 1, step):
            session.advance(now)
            if on_progress is not None:
                on_progress(now / 1e9)
            if session.client.ended():
                break
        estimates = session.client.estimates()
        kept = [estimate for estimate in estimates if nanoseconds(estimate.time) <= horizon]
        return TrackRun(source, target, relay, kept)
    finally:
        session.close()
        context.try_shutdown()


def same_run(first: TrackRun, second: TrackRun) -> bool:
    """Same relay, statuses, times and predicted states, to the bit of the messages.

    TrackEstimate carries metres (REP-103), so states compare as metres: a
    state read back from a message is its metres times 100, whose metres are
    the message's again, bit for bit.
    """

    def table(run: TrackRun) -> tuple[list[str], np.ndarray]:
        rows = [
            [estimate.time, estimate.sample_time]
            + (
                [
                    *estimate.kalman.position,
                    *estimate.kalman.velocity,
                    *estimate.kalman.acceleration,
                ]
                if estimate.kalman is not None
                else [np.nan] * 9
            )
            for estimate in run.estimates
        ]
        table: np.ndarray = np.array(rows).reshape(-1, 11)
        table[:, 2:] = to_metres(table[:, 2:])
        return [estimate.status for estimate in run.estimates], table

    (first_status, first_rows), (second_status, second_rows) = table(first), table(second)
    return (
        first.relay == second.relay
        and first_status == second_status
        and np.array_equal(first_rows, second_rows, equal_nan=True)
    )
