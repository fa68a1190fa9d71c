"""The coordinator node: the round clock of path discovery, and the heuristics' mover.

It carries two of the protocol's state machines over ROS: the
:class:`~swazure_ros.protocol.rounds.RoundClock` of a discovery run
(docs/protocol.md) and the :class:`~swazure_ros.protocol.moves.MoveRun` of a
heuristic made by the swarm. Each callback turns a message into one event of
the running machine and publishes what the machine answers; a timer gives
the machines the time, so that every wait ends by its deadline. Runs asked
for while one is under way wait their turn, in order.

Its service ``coordinator/compute_pose`` (:class:`~.pose_service.PoseService`)
runs one source's search for one target on demand. The coordinator only
clocks; labels travel from FLS to FLS, and only FLSs sum vectors.

The node wires parts of one job each: :class:`Outbox` (what it publishes,
counted) and, pure logic in ``protocol/``,
:class:`~swazure_ros.protocol.run_queue.RunQueue` (runs wait their turn),
:class:`~swazure_ros.protocol.membership.Membership` (who takes part:
departed, gone, back, and the radios to hear) and
:class:`~swazure_ros.protocol.positions.Positions` (where each FLS is, by the
world's revisions).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from functools import partial

from builtin_interfaces.msg import Time
from rclpy.context import Context
from rclpy.publisher import Publisher

# What a run asked of the coordinator returns; app/ waits on it through this module.
from rclpy.task import Future as Future
from std_msgs.msg import Header
from swazure_interfaces.msg import (
    Departed,
    DiscoveryControl,
    Heartbeat,
    MoveCommands,
    PathWalk,
    PoseEstimates,
    RoundAck,
    WorldState,
)

from ...core.evaluation import Evaluation
from ...core.fit import PATH
from ...core.fit_measurements import fit_layers
from ...core.geometry import Swarm
from ...core.paths import check_policy
from ...core.sensor import Sensor
from ...protocol.discovery.buckets import bucket_width
from ...protocol.discovery.messages import Control
from ...protocol.membership import Membership
from ...protocol.moves import Move, MoveRun, Walk
from ...protocol.plausible import implausible_estimates
from ...protocol.positions import Positions
from ...protocol.rounds import RoundClock, RoundTimes, StallClock
from ...protocol.run_queue import Job, Machine, RunQueue
from ...protocol.runs import DiscoveryResult, MoveResult, Traffic
from ..convert.discovery import (
    alive_from_message,
    control_message,
    estimates_from_message,
    moves_message,
    sent_from_message,
    walk_fields,
)
from ..convert.sensing import world_positions
from ..plumbing.liveness import FlsLiveness
from ..plumbing.names import (
    ACK_TOPIC,
    CONTROL_TOPIC,
    COORDINATOR,
    DEPARTED_QOS,
    DEPARTED_TOPIC,
    ESTIMATES_TOPIC,
    HEARTBEAT_TOPIC,
    HEARTBEATS_READ_QOS,
    LIVENESS_GRACE,
    MOVE_QOS,
    MOVE_TOPIC,
    RADIO_TOPIC,
    ROUND_QOS,
    UNKNOWN_NODE,
    WALKS_TOPIC,
    WORLD_QOS,
    WORLD_REACH,
    WORLD_TOPIC,
    fls_id_of,
    node_name,
)
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterSpec, seconds
from ..security.auth import SwarmKey, signed_at
from ..security.guard import Guard, check
from ..security.records import record_parser, record_writer
from .pose_service import PoseService

#: A walk's bytes from its fields (:mod:`..security.records`): a Move's batch sends one a pair.
_WALK_BYTES = record_writer(PathWalk)
#: Characters in a host node's name, at most (ROS names are far shorter).
MAX_NAME = 255
#: Seconds between the coordinator's looks at its deadlines.
TICK = 0.05
#: A tick this much later than due means the process was busy, not that FLSs were silent.
STALL = 0.5

Action = Control | Move | Walk


ROUND_TIMEOUT = ParameterSpec(
    "round_timeout",
    10.0,
    "s without progress after which silent FLSs have departed, at least: ten times the slow "
    "end of the swarm's recent rounds when that is longer (set while running too: the next "
    "run takes it)",
    seconds(),
)
LIVENESS_PERIOD = ParameterSpec(
    "liveness_period", 0.5, "s between looks at the graph for FLS nodes gone", seconds()
)
LIVENESS_GRACE_SPEC = ParameterSpec(
    "liveness_grace",
    LIVENESS_GRACE,
    "s an FLS node must stay off the graph before it is gone",
    seconds(allow_zero=True),
)
#: The parameters the coordinator declares.
PARAMETERS = (ROUND_TIMEOUT, LIVENESS_PERIOD, LIVENESS_GRACE_SPEC)


class Outbox:
    """What the coordinator publishes, serialized by the swarm's key and counted."""

    def __init__(self, node: SwarmNode, key: SwarmKey, traffic: Traffic) -> None:
        self.key = key
        self.traffic = traffic
        self.control = node.create_publisher(DiscoveryControl, CONTROL_TOPIC, ROUND_QOS)
        self.moves = node.create_publisher(MoveCommands, MOVE_TOPIC, MOVE_QOS)
        self._walks = node.create_publisher(PathWalk, WALKS_TOPIC, ROUND_QOS)
        self._gone = node.create_publisher(Departed, DEPARTED_TOPIC, DEPARTED_QOS)

    def send(self, actions: Sequence[Action], stamp: Time) -> None:
        """Publish what a run's machine asks for."""
        groups: dict[int, list[Move]] = {}  # moves made together go in one message
        for action in actions:
            if isinstance(action, Control):
                self._publish(self.control, CONTROL_TOPIC, control_message(action, stamp))
            elif isinstance(action, Move):
                groups.setdefault(action.group, []).append(action)
            else:
                data = _WALK_BYTES(walk_fields(action, stamp), self.key.auth)
                self.traffic.count(WALKS_TOPIC, len(data))
                self._walks.publish(data)
        for moves in groups.values():
            self._publish(self.moves, MOVE_TOPIC, moves_message(moves, stamp))

    def send_gone(self, gone: set[int], stamp: Time) -> None:
        """The list of the gone, latched on /swarm/departed, as it is now."""
        departed = Departed(header=Header(stamp=stamp), fls_ids=sorted(gone))
        self._gone.publish(self.key.serialize(departed))

    def _publish(self, publisher: Publisher, topic: str, message: object) -> None:
        data = self.key.serialize(message)
        self.traffic.count(topic, len(data))
        publisher.publish(data)


class Coordinator(SwarmNode):
    """Clocks discovery runs and makes heuristics' moves over the FLS nodes of a swarm."""

    def __init__(
        self,
        fls_ids: Iterable[int],
        hosts: int,
        *,
        shape: Swarm,
        sensor: Sensor,
        namespace: str = "swarm",
        context: Context | None = None,
        key: SwarmKey | None = None,
        parameter_services: bool = False,
    ) -> None:
        super().__init__(
            COORDINATOR,
            namespace=namespace,
            context=context,
            parameter_services=parameter_services,
        )
        # The next run takes a new value (ros2 param set); a run under way keeps its own.
        self.round_timeout = self.declare(ROUND_TIMEOUT, partial(setattr, self, "round_timeout"))
        self.liveness_period = self.declare(LIVENESS_PERIOD)
        self.liveness_grace = self.declare(LIVENESS_GRACE_SPEC)
        # The display's shape, every FLS at its assigned point, and the sensor: what the
        # swarm knows (common knowledge), and what moves are planned on. Not the pairs: a
        # display's are gigabytes, and each FLS's process has its own.
        self.shape = shape
        self.sensor = sensor
        self.fls_ids = frozenset(int(fls_id) for fls_id in fls_ids)
        self.guard = Guard(self, key)
        self.key = self.guard.key
        self.traffic = Traffic()
        self.outbox = Outbox(self, self.key, self.traffic)
        self.membership = Membership(hosts, own_radio=node_name, radio_fls=fls_id_of)
        self.positions = Positions(shape, self.fls_ids)
        self.runs: RunQueue[Future] = RunQueue()
        # Deadlines stand still while this process is too busy to hear anything, and
        # follow how long the swarm's rounds take (every run's rounds measured).
        self._deadlines = StallClock(TICK, STALL, time.monotonic())
        self.round_times = RoundTimes()
        # The radios whose last heartbeat said they hear the controls (their node names):
        # at most one per FLS and per process, whatever names a stranger makes up.
        self._hearing: set[str] = set()
        self._radios_at_most = len(self.fls_ids) + hosts
        self._read_ack = self.guard.reader(RoundAck)
        # A report a source, a walk a pair: read as bytes (ros.security.records).
        self._read_estimates = self.guard.record_reader(record_parser(PoseEstimates))
        guard = self.guard.wrap
        self._acks = self.create_subscription(
            RoundAck, ACK_TOPIC, guard(ACK_TOPIC, self._on_ack), ROUND_QOS, raw=True
        )
        self.create_subscription(
            PoseEstimates,
            ESTIMATES_TOPIC,
            guard(ESTIMATES_TOPIC, self._on_estimates),
            ROUND_QOS,
            raw=True,
        )
        self.create_subscription(PathWalk, WALKS_TOPIC, self._on_walk, ROUND_QOS, raw=True)
        self.guard.subscribe(WorldState, WORLD_TOPIC, self._on_world, WORLD_QOS)
        self.guard.subscribe(Heartbeat, HEARTBEAT_TOPIC, self._on_heartbeat, HEARTBEATS_READ_QOS)
        # One source's search for one target, on demand (swazure query).
        self.pose_service = PoseService(
            self, sensor, shape.radius, self.fls_ids, self.departed_next, self.discover
        )
        # Liveness: an FLS whose node leaves the graph is gone at once, not after a round's
        # timeout. The graph is DDS's own liveliness: a stopped node is removed at once, a
        # killed process's nodes when its participant's lease runs out.
        self._liveness = FlsLiveness(self, self.get_namespace(), self.liveness_grace)
        self.create_timer(TICK, self._on_tick)
        self.create_timer(self.liveness_period, self._on_liveness)

    def hosts_matched(self) -> bool:
        """Every host's radio hears the controls; the coordinator hears its acks.

        Matched endpoints, not names in the graph: a message sent to a reader
        not matched yet is lost. Both ends must have matched: the coordinator
        sees its control writer's readers and its ack reader's writers, and
        each radio says in its heartbeat that its reader of the controls has
        matched their writer (:class:`~.heartbeats.Heartbeats`). Whether the
        hosts' radios have matched each other's transmitters no one host can
        see: a round that a host never acknowledges restarts its phase
        (:class:`~swazure_ros.protocol.rounds.RoundClock`).
        """
        hosts = self.membership.hosts
        gone = self.membership.gone
        hearing = [host for host in self._hearing if fls_id_of(host) not in gone]
        return (
            self.outbox.control.get_subscription_count() >= hosts
            and self._acks.get_publisher_count() >= hosts
            and len(hearing) >= hosts
        )

    # Runs ------------------------------------------------------------------

    def discover(
        self,
        policy: str,
        sources: list[int] | None = None,
        targets: list[int] | None = None,
        estimator: str = PATH,
    ) -> Future:
        """Run discovery: every FLS for every blind neighbour, or sources[k] for targets[k].

        ``estimator``: how sources estimate (``core.fit.SWARM_ESTIMATORS``).
        Returns a future of the :class:`DiscoveryResult`. ValueError for a
        policy that this swarm's sensor cannot run (least-error without error).
        """
        bucket_width(self.sensor, self.shape.radius, check_policy(policy))

        def begin(run_id: int) -> Machine:
            clock = RoundClock(
                run_id,
                policy,
                self.fls_ids,
                self.membership.hosts,
                self.round_timeout,
                departed=self.membership.departed,
                sources=sources or (),
                targets=targets or (),
                estimator=estimator,
                fit_layers=fit_layers(self.sensor),
            )
            clock.times = self.round_times
            return clock

        return self._enqueue(begin)

    def make_moves(
        self,
        evaluation: Evaluation,
        technique: str,
        threshold: int = 10,
        source_body: bool = False,
    ) -> Future:
        """A heuristic on every BLOCKED pair of a whole-swarm run, its moves made for real.

        ``evaluation`` is the run's (``protocol.discovery.reported.evaluation_of``);
        ``technique`` is Move Obstructing or Move Source (probing up to
        ``threshold`` steps of r; ``source_body``: planned with the source's body at its
        probe point checked). Returns a future of the :class:`MoveResult`.
        """
        # Planned now, so that a bad technique fails here and not inside a callback.
        planned = MoveRun(0, evaluation, technique, threshold, 0, self.round_timeout, source_body)

        def begin(run_id: int) -> Machine:
            planned.run_id = run_id
            planned.revision = self.positions.revision
            planned.asked_revision = self.positions.asked_revision
            return planned

        return self._enqueue(begin)

    def _enqueue(self, begin: Callable[[int], Machine]) -> Future:
        future = Future()
        self.runs.add(begin, future)
        self._start_next()
        return future

    def _start_next(self) -> None:
        while (waited := self.runs.next_waited()) is not None:
            # A control sent before every radio has matched is lost, and the round would
            # wait out its timeout: a coordinator started with its swarm (one process per
            # FLS) waits for the radios first, for a round timeout at most.
            if not self.hosts_matched() and waited < self.round_timeout:
                return  # the tick tries again
            # A run starts from what the graph shows now, not at the last look.
            self._look_at_graph()
            if not self.key.active:
                self._retry_silent()
            machine = self.runs.begin_next(self.traffic)
            self._act(machine.start(self._now()))

    def _act(self, actions: Sequence[Action]) -> None:
        """Publish what the running machine asks for; finish its run when it is done."""
        self.outbox.send(actions, self.get_clock().now().to_msg())
        machine = self.runs.running()
        if machine is None:
            return
        for warning in machine.warnings:
            self.get_logger().warning(warning)  # type: ignore[no-untyped-call]
        machine.warnings.clear()
        if machine.done:
            job = self.runs.finish()
            job.future.set_result(self._result(job, machine))
            self._start_next()

    def _result(self, job: Job[Future], machine: Machine) -> DiscoveryResult | MoveResult:
        seconds = time.perf_counter() - job.began
        traffic = self.traffic.since(job.traffic)
        if isinstance(machine, RoundClock):
            outcome = machine.outcome
            assert outcome is not None
            self.membership.settle(outcome.departed)
            return DiscoveryResult(machine.run_id, machine.policy, outcome, seconds, traffic)
        moved = machine.outcome
        assert moved is not None
        self.positions.asked_revision = machine.asked_revision
        return MoveResult(machine.run_id, moved, seconds, traffic)

    def progress(self) -> str:
        """How far the running job is ("" when idle), for a person watching."""
        machine = self.runs.running()
        return machine.progress if machine is not None else ""

    def departed_next(self) -> frozenset[int]:
        """The FLSs the next run goes without (and queries naming them are refused).

        The departed; under --no-key, those gone from the graph only: without a
        key nothing an FLS says is its own, and a peer's forged controls can
        silence any FLS for a run (docs/security.md), so a departure for
        silence lasts for its run, and the next asks every FLS the graph shows.
        """
        membership = self.membership
        if self.key.active:
            return frozenset(membership.departed)
        return frozenset(membership.departed & membership.gone)

    def departed_so_far(self) -> frozenset[int]:
        """The FLSs known departed: earlier runs' and, so far, the running discovery's."""
        machine = self.runs.running()
        running = machine.departed if isinstance(machine, RoundClock) else set()
        return frozenset(self.membership.departed | running)

    # Callbacks: one message -> one event of the running machine -------------

    def _now(self) -> float:
        """Seconds on the deadlines' clock: monotonic time less this process's stalls."""
        return self._deadlines(time.monotonic())

    def _on_tick(self) -> None:
        if not self._deadlines.tick(time.monotonic()):
            return  # whatever arrived meanwhile waits behind this tick: hear it first
        self._start_next()
        machine = self.runs.running()
        if machine is not None:
            self._act(machine.on_tick(self._now()))

    def _on_liveness(self) -> None:
        if self._liveness.due():  # a large swarm's graph is looked at less often
            self._look_at_graph()

    def _look_at_graph(self) -> None:
        membership = self.membership
        # On the deadlines' clock: an absence does not grow while this process stalls.
        newly = self._liveness.look(membership.gone, self._now())
        if self._liveness.back:
            self._take_back(self._liveness.back, "on the graph again")
        if len(membership.radios) < membership.hosts:
            # The radios, by the names of their nodes, while they are on the graph: the
            # acks' writers (an FLS may die before its radio ever acknowledged a round).
            writers = self.get_publishers_info_by_topic(self._acks.topic_name)
            # A writer whose participant's node names have not arrived yet is named
            # UNKNOWN_NODE: no radio's name, and it would take a radio's place in the count.
            membership.see_radios(
                info.node_name for info in writers if info.node_name != UNKNOWN_NODE
            )
        if not newly:
            return
        radios = membership.lose(newly)
        machine = self.runs.running()
        if isinstance(machine, RoundClock):
            self._act(machine.on_gone(newly, self._now(), radios=radios))
        self._publish_gone()

    def _publish_gone(self) -> None:
        self.outbox.send_gone(self.membership.gone, self.get_clock().now().to_msg())

    def _take_back(self, back: set[int], how: str) -> None:
        """FLSs departed and back take part again (:meth:`Membership.take_back`)."""
        self.membership.take_back(back, in_run=self.runs.running() is not None)
        listed = ", ".join(map(str, sorted(back)))
        logger = self.get_logger()  # type: ignore[no-untyped-call]
        logger.info(f"FLS {listed} back ({how}): taking part again")
        self._publish_gone()

    def _retry_silent(self) -> None:
        """Under --no-key, as a run starts: FLSs departed for silence alone take part again."""
        silent = self.membership.departed - self.membership.gone
        if silent:
            self._take_back(silent, "on the graph as a run starts, without a key")

    def _on_ack(self, data: bytes) -> None:
        self.traffic.count(ACK_TOPIC, len(data))
        ack = self._read_ack(data)
        check(0 < len(ack.host) <= MAX_NAME, "a host name of no or too many characters")
        # Only a signed ack says who speaks: without a key, anyone could write it.
        signed = self.key.active
        membership = self.membership
        if (
            signed
            and membership.departed
            and (back := membership.back_by(ack.host, signed_at(ack)))
        ):
            self._take_back(back, "speaking again")
        clock = self.runs.running(ack.run_id)
        if isinstance(clock, RoundClock):
            if not ack.delivered:
                # Who spoke: the coordinator hears no offer itself (docs/protocol.md).
                sent = sent_from_message(ack, self.positions.ids)
                self.membership.hear(ack.host, sent.senders)
                self.traffic.count(RADIO_TOPIC, sent.bytes, len(sent.senders))
                self._act(clock.on_sent(int(ack.round), sent, self._now()))
                return
            self._act(
                clock.on_ack(
                    int(ack.round), ack.host, self._now(), int(ack.repairs), int(ack.lost)
                )
            )

    def _on_heartbeat(self, message: Heartbeat) -> None:
        """A radio says it is alive: whether it hears the controls, and how late it is.

        A radio behind whose wait the running round holds gets more time
        (``RoundClock.on_alive``, bounded); nobody is taken back by a
        heartbeat, and nobody is kept from departing when the graph shows
        its node gone (docs/protocol.md, "Slow is not dead").
        """
        alive = alive_from_message(message)
        check(0 < len(alive.host) <= MAX_NAME, "a host name of no or too many characters")
        if alive.hears_controls:
            known = alive.host in self._hearing
            check(known or len(self._hearing) < self._radios_at_most, "more radios than FLSs")
            self._hearing.add(alive.host)
            # Known before the swarm is called up (hosts_matched counts these): a radio
            # killed right after still leaves the hosts with its FLS.
            self.membership.see_radios((alive.host,))
        else:
            self._hearing.discard(alive.host)
        clock = self.runs.running()
        if alive.late > 0.0 and isinstance(clock, RoundClock):
            voices = self.membership.voices(alive.host)
            self._act(clock.on_alive(alive.host, voices, self._now()))

    def _on_estimates(self, data: bytes) -> None:
        self.traffic.count(ESTIMATES_TOPIC, len(data))
        message = self._read_estimates(data)
        source = int(message.source_id)
        machine = self.runs.running(message.run_id)
        if machine is None and self.key.active:
            return  # the swarm's own report of a run that is over
        estimates = estimates_from_message(message, self.positions.ids)
        if not self.key.active:
            # Signed, a report is the swarm's own; unsigned, it may be anyone's: checked
            # whether or not its run is still on, so that a forgery is seen whenever it comes.
            why = implausible_estimates(
                estimates, source, self.positions.where, self.sensor, self.shape.radius
            )
            check(why is None, f"implausible: {why}")
        if machine is not None:
            self._act(machine.on_estimates(source, estimates, self._now()))

    def _on_world(self, state: WorldState) -> None:
        check(state.revision < 2**63, f"revision {state.revision} out of range")
        revision = int(state.revision)
        if self.positions.takes(revision):  # an older revision's positions are not read
            ids, points = world_positions(state, self.positions.ids, WORLD_REACH)
            self.positions.hear(revision, ids, points)
        machine = self.runs.running()
        if isinstance(machine, MoveRun):
            self._act(machine.on_revision(self.positions.revision, self._now()))

    def _on_walk(self, data: bytes) -> None:
        self.traffic.count(WALKS_TOPIC, len(data))
