"""The coordinator: the round clock of path discovery, and the heuristics' mover.

It runs discovery (docs/protocol.md): START a phase, open rounds one by one
while FLSs broadcast their labels, close each round when every FLS has
broadcast and every process's radio has delivered, END the run and collect
the sources' estimates. An FLS that stays silent for ``round_timeout``
seconds has departed: the phase restarts without it, so no search waits on a
gone node and no path runs through it.

Its service ``coordinator/compute_pose`` (swazure_interfaces/ComputePose)
runs one source's search for one target on demand. The coordinator only
clocks; labels travel from FLS to FLS, and only FLSs sum vectors.

After a whole-swarm run, :meth:`Coordinator.make_moves` applies Move
Obstructing or Move Source: the core engine plans the moves (which
obstructers step aside and where, or where a source probes, from the
original shape, as the engine does), the coordinator makes them batch by
batch on ``move_commands``, sends a path walk to the source of every pair of
the batch (the FLSs of the path measure their hops again and sum them), and
returns the moved FLSs to their points.

The coordinator is a handful of entities, so it runs on a stock executor,
which can await inside callbacks (the FLS nodes' events executor cannot).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from geometry_msgs.msg import Vector3
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.task import Future
from swazure_interfaces.msg import (
    DiscoveryControl,
    MoveCommand,
    PathOffer,
    PathWalk,
    PoseEstimates,
    RoundAck,
    WorldState,
)
from swazure_interfaces.srv import ComputePose

from ..core.discovery import PHASES, Estimate, RoundTally, evaluation_of
from ..core.evaluate import SWEET_PATH, Evaluation
from ..core.heuristics import (
    MOVE_OBSTRUCTING,
    MOVE_SOURCE,
    HeuristicResult,
    apply,
    move_batches,
    move_obstructing,
    move_source,
    walked,
)
from ..core.paths import FEWEST_HOPS, check_policy
from ..sim.world import World
from .convert import estimate_from_message, estimate_message
from .fls_node import (
    COMPUTE_POSE_SERVICE,
    ESTIMATES_TOPIC,
    POLICY_NAMES,
    RADIO_TOPIC,
    ROUND_QOS,
    ParameterError,
)
from .host import ACK_TOPIC, CONTROL_TOPIC, WALKS_TOPIC
from .world_node import MOVE_QOS, MOVE_TOPIC, WORLD_QOS, WORLD_TOPIC

POLICY_CODES = {name: code for code, name in POLICY_NAMES.items()}


@dataclass
class Traffic:
    """Messages and bytes sent during discovery, per topic."""

    messages: dict[str, int] = field(default_factory=dict)
    bytes: dict[str, int] = field(default_factory=dict)

    def count(self, topic: str, size: int) -> None:
        """Count one message of ``size`` bytes on ``topic``."""
        self.messages[topic] = self.messages.get(topic, 0) + 1
        self.bytes[topic] = self.bytes.get(topic, 0) + size

    @property
    def total_messages(self) -> int:
        """Messages on every topic."""
        return sum(self.messages.values())

    @property
    def total_bytes(self) -> int:
        """Bytes on every topic (serialised payloads)."""
        return sum(self.bytes.values())


@dataclass
class DiscoveryResult:
    """One discovery run: every source's estimates and what it took."""

    run_id: int
    policy: str
    estimates: dict[int, list[Estimate]]  # source id -> estimates
    departed: frozenset[int]
    rounds: int
    restarts: int
    seconds: float
    traffic: Traffic


@dataclass
class MoveResult:
    """A heuristic made by the swarm: the evaluation after it and what it took."""

    run_id: int
    evaluation: Evaluation  # the plain run with the resolved pairs made SWEET
    heuristic: HeuristicResult  # the engine's plan, resolved where the walk arrived
    batches: int
    moved: int  # move commands sent, returns included
    walks: int
    seconds: float
    traffic: Traffic


class _Timeout:
    """A wait that ended by its deadline."""


class Coordinator(Node):
    """Clocks discovery runs over the FLS nodes of a swarm."""

    def __init__(
        self,
        fls_ids: Iterable[int],
        hosts: int,
        *,
        world: World | None = None,
        namespace: str = "swarm",
        context: Context | None = None,
    ) -> None:
        super().__init__(
            "coordinator",
            namespace=namespace,
            context=context,
            enable_rosout=False,
            start_parameter_services=False,
        )
        try:
            timeout = self.declare_parameter(
                "round_timeout",
                10.0,
                ParameterDescriptor(
                    description="seconds without progress after which silent FLSs have departed"
                ),
            ).value
        except ParameterException as err:
            raise ParameterError(f"{self.get_fully_qualified_name()}: {err}") from err
        if not isinstance(timeout, float) or not timeout > 0:
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: parameter round_timeout must be "
                f"a positive number of seconds, got {timeout!r}"
            )
        self.round_timeout = timeout
        self.world = world  # the original shape, for planning moves
        self.fls_ids = frozenset(int(fls_id) for fls_id in fls_ids)
        self.hosts = hosts
        self.departed: set[int] = set()
        self.traffic = Traffic()
        self._control = self.create_publisher(DiscoveryControl, CONTROL_TOPIC, ROUND_QOS)
        self.create_subscription(PathOffer, RADIO_TOPIC, self._on_offer, ROUND_QOS, raw=True)
        self.create_subscription(RoundAck, ACK_TOPIC, self._on_ack, ROUND_QOS, raw=True)
        self.create_subscription(
            PoseEstimates, ESTIMATES_TOPIC, self._on_estimates, ROUND_QOS, raw=True
        )
        # The service awaits whole runs: in the default mutually exclusive group it
        # would lock out the very subscriptions that move a run on, and requests
        # that arrive meanwhile must queue (see _acquire) rather than wait unseen.
        self.create_service(
            ComputePose,
            f"~/{COMPUTE_POSE_SERVICE}",
            self._on_compute_pose,
            callback_group=ReentrantCallbackGroup(),
        )
        self._moves = self.create_publisher(MoveCommand, MOVE_TOPIC, MOVE_QOS)
        self._walks = self.create_publisher(PathWalk, WALKS_TOPIC, ROUND_QOS)
        self.create_subscription(PathWalk, WALKS_TOPIC, self._on_walk, ROUND_QOS, raw=True)
        self.create_subscription(WorldState, WORLD_TOPIC, self._on_world, WORLD_QOS)
        self.create_timer(0.05, self._check_deadline)
        self._revision = 0  # the newest world revision seen
        self._asked_revision = 0  # the revision our last group of moves makes
        self._awaited_revision: int | None = None
        self._walking: set[tuple[int, int]] = set()
        self._walked: dict[tuple[int, int], Estimate] = {}
        self._next_run = 1
        self._run_id = 0
        self._tally: RoundTally | None = None
        self._round = -1
        self._collected: dict[int, list[Estimate]] = {}
        self._collecting: frozenset[int] = frozenset()
        self._waiter: Future | None = None
        self._deadline = 0.0
        self._queue: list[Future] = []
        self._busy = False

    # Runs ------------------------------------------------------------------

    async def discover(
        self,
        policy: str,
        sources: list[int] | None = None,
        targets: list[int] | None = None,
    ) -> DiscoveryResult:
        """Run discovery: every FLS for every blind neighbour, or sources[k] for targets[k]."""
        check_policy(policy)
        await self._acquire()
        try:
            return await self._discover(policy, sources or [], targets or [])
        finally:
            self._release()

    async def _discover(
        self, policy: str, sources: list[int], targets: list[int]
    ) -> DiscoveryResult:
        began = time.perf_counter()
        run_id = self._next_run
        self._next_run += 1
        self._run_id = run_id
        traffic_before = (dict(self.traffic.messages), dict(self.traffic.bytes))
        round_ = 0
        restarts = 0
        for phase in PHASES:
            while True:
                live = self.fls_ids - self.departed
                self._send(
                    run_id,
                    DiscoveryControl.COMMAND_START,
                    phase,
                    policy,
                    round_,
                    live,
                    sources=sources,
                    targets=targets,
                )
                finished: set[int] = set()
                newly: list[int] = []
                restart = False
                while True:
                    tally = RoundTally(frozenset(live), self.hosts)
                    self._tally, self._round = tally, round_
                    self._send(
                        run_id,
                        DiscoveryControl.COMMAND_ROUND,
                        phase,
                        policy,
                        round_,
                        live,
                        finished=newly,
                    )
                    outcome = await self._wait()
                    self._tally = None
                    round_ += 1
                    if isinstance(outcome, _Timeout) and tally.silent:
                        self.departed |= tally.silent
                        self.get_logger().warning(
                            f"run {run_id}: FLS {sorted(tally.silent)} silent for "
                            f"{self.round_timeout:g} s, departed; phase {phase} restarts"
                        )
                        restart = True
                        break
                    newly = sorted(tally.finished - finished)
                    finished |= tally.finished
                    if tally.quiet:
                        break
                if not restart:
                    break
                restarts += 1
        live = self.fls_ids - self.departed
        expected = frozenset(sources) & live if sources else live
        self._collected, self._collecting = {}, expected
        self._send(run_id, DiscoveryControl.COMMAND_END, 0, policy, round_, live)
        outcome = await self._wait() if expected else None
        if isinstance(outcome, _Timeout):
            gone = expected - set(self._collected)
            self.departed |= gone
            self.get_logger().warning(f"run {run_id}: no estimates from FLS {sorted(gone)}")
        collected, self._collecting = self._collected, frozenset()
        traffic = Traffic(
            {k: v - traffic_before[0].get(k, 0) for k, v in self.traffic.messages.items()},
            {k: v - traffic_before[1].get(k, 0) for k, v in self.traffic.bytes.items()},
        )
        return DiscoveryResult(
            run_id,
            policy,
            collected,
            frozenset(self.departed),
            round_,
            restarts,
            time.perf_counter() - began,
            traffic,
        )

    async def make_moves(
        self, plain: DiscoveryResult, technique: str = MOVE_OBSTRUCTING, threshold: int = 10
    ) -> MoveResult:
        """A heuristic on every BLOCKED pair of a whole-swarm run, its moves made for real.

        ``technique`` is Move Obstructing or Move Source (probing up to
        ``threshold`` steps of r).
        """
        if self.world is None:
            raise ValueError("the coordinator plans moves from the world it was given: none")
        if technique not in (MOVE_OBSTRUCTING, MOVE_SOURCE):
            raise ValueError(f"no moves to make for technique {technique!r}")
        await self._acquire()
        try:
            return await self._make_moves(plain, technique, threshold)
        finally:
            self._release()

    async def _make_moves(
        self, plain: DiscoveryResult, technique: str, threshold: int
    ) -> MoveResult:
        began = time.perf_counter()
        world = self.world
        assert world is not None
        run_id = self._next_run
        self._next_run += 1
        self._run_id = run_id
        traffic_before = (dict(self.traffic.messages), dict(self.traffic.bytes))
        evaluation = evaluation_of(world.hood, plain.policy, plain.estimates)
        if technique == MOVE_OBSTRUCTING:
            plan, kind = move_obstructing(evaluation), MoveCommand.KIND_STEP_ASIDE
        else:
            plan, kind = move_source(evaluation, threshold), MoveCommand.KIND_PROBE
        batches = move_batches(evaluation, plan)
        ids, pairs = world.ids, evaluation.pairs
        vectors = {}
        moved = walks = 0
        for batch in batches:
            moves: dict[int, tuple[int, int, object]] = {}  # FLS id -> (source, target, to)
            for pair in batch.tolist():
                served = (int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))
                for fls, _, to in plan.moves(pair):
                    moves[int(ids[fls])] = (*served, to)
            revision = await self._move_together(kind, moves)
            moved += len(moves)
            walking = {}
            for pair in batch.tolist():
                path = plan.paths.nodes[plan.paths.offsets[pair] : plan.paths.offsets[pair + 1]]
                walk = PathWalk(run_id=run_id, revision=revision, path=ids[path].tolist())
                walk.source_id, walk.target_id = walk.path[0], walk.path[-1]
                walking[(walk.source_id, walk.target_id)] = pair
                walk.header.stamp = self.get_clock().now().to_msg()
                self._publish(self._walks, WALKS_TOPIC, walk)
            walks += len(walking)
            for key, found in (await self._walk(walking)).items():
                if found.status == SWEET_PATH:
                    vectors[walking[key]] = found.vector
            await self._move_together(MoveCommand.KIND_RETURN, moves)
            moved += len(moves)
        heuristic = walked(plan, vectors)
        traffic = Traffic(
            {k: v - traffic_before[0].get(k, 0) for k, v in self.traffic.messages.items()},
            {k: v - traffic_before[1].get(k, 0) for k, v in self.traffic.bytes.items()},
        )
        return MoveResult(
            run_id,
            apply(evaluation, heuristic),
            heuristic,
            len(batches),
            moved,
            walks,
            time.perf_counter() - began,
            traffic,
        )

    async def _move_together(self, kind: int, moves: dict[int, tuple[int, int, object]]) -> int:
        """Make ``moves`` ({FLS id: (source, target, position)}) in one revision; return it."""
        assert self.world is not None
        self._asked_revision = max(self._asked_revision, self._revision) + 1
        revision = self._asked_revision
        for fls_id, (source, target, to) in moves.items():
            command = MoveCommand(
                fls_id=fls_id,
                kind=kind,
                source_id=source,
                target_id=target,
                group=revision,
                group_size=len(moves),
            )
            if kind != MoveCommand.KIND_RETURN:
                shift = to - self.world.home.points[self.world.index(fls_id)]  # type: ignore[operator]
                command.displacement = Vector3(x=shift[0], y=shift[1], z=shift[2])
            command.header.stamp = self.get_clock().now().to_msg()
            self._publish(self._moves, MOVE_TOPIC, command)
        self._awaited_revision = revision
        self._progress()
        outcome = await self._wait()
        self._awaited_revision = None
        if isinstance(outcome, _Timeout):
            self.get_logger().warning(f"world revision {revision} not seen: moves may be lost")
        return revision

    async def _walk(self, walking: dict[tuple[int, int], int]) -> dict[tuple[int, int], Estimate]:
        """Wait for the sources' results of the walks ``walking``; those that came back."""
        self._walking, self._walked = set(walking), {}
        self._progress()
        outcome = await self._wait()
        if isinstance(outcome, _Timeout):
            missing = sorted(self._walking - set(self._walked))
            self.get_logger().warning(f"no result of the path walks {missing[:10]}")
        walked_, self._walking = self._walked, set()
        return walked_

    def _publish(self, publisher: Any, topic: str, message: object) -> None:
        data = serialize_message(message)
        self.traffic.count(topic, len(data))
        publisher.publish(data)

    def _send(
        self,
        run_id: int,
        command: int,
        phase: int,
        policy: str,
        round_: int,
        live: frozenset[int],
        *,
        sources: list[int] = (),  # type: ignore[assignment]
        targets: list[int] = (),  # type: ignore[assignment]
        finished: list[int] = (),  # type: ignore[assignment]
    ) -> None:
        control = DiscoveryControl(
            run_id=run_id,
            command=command,
            phase=phase,
            policy=POLICY_CODES[policy],
            round=round_,
            expected=len(live),
            source_ids=list(sources),
            target_ids=list(targets),
            finished_ids=list(finished),
            departed_ids=sorted(self.departed),
        )
        control.header.stamp = self.get_clock().now().to_msg()
        data = serialize_message(control)
        self.traffic.count(CONTROL_TOPIC, len(data))
        self._deadline = time.monotonic() + self.round_timeout
        self._control.publish(data)

    # Waiting -----------------------------------------------------------------

    async def _acquire(self) -> None:
        if self._busy:
            turn = Future()
            self._queue.append(turn)
            await turn
        self._busy = True

    def _release(self) -> None:
        self._busy = False
        if self._queue:
            self._busy = True
            self._queue.pop(0).set_result(None)

    async def _wait(self) -> object:
        self._waiter = Future()
        return await self._waiter

    def _wake(self, value: object = None) -> None:
        waiter, self._waiter = self._waiter, None
        if waiter is not None and not waiter.done():
            waiter.set_result(value)

    def _progress(self) -> None:
        self._deadline = time.monotonic() + self.round_timeout

    def _check_deadline(self) -> None:
        if self._waiter is not None and time.monotonic() > self._deadline:
            self._wake(_Timeout())

    # Callbacks ---------------------------------------------------------------

    def _on_offer(self, data: bytes) -> None:
        self.traffic.count(RADIO_TOPIC, len(data))
        tally = self._tally
        if tally is None:
            return
        offer: Any = deserialize_message(data, PathOffer)
        if offer.run_id != self._run_id or offer.round != self._round:
            return
        tally.hear(int(offer.sender_id), len(offer.source_ids), offer.pending, offer.finished)
        self._progress()
        if tally.complete:
            self._wake()

    def _on_ack(self, data: bytes) -> None:
        self.traffic.count(ACK_TOPIC, len(data))
        tally = self._tally
        if tally is None:
            return
        ack: Any = deserialize_message(data, RoundAck)
        if ack.run_id == self._run_id and ack.round == self._round:
            tally.ack(ack.host)
            self._progress()
            if tally.complete:
                self._wake()

    def _on_world(self, state: WorldState) -> None:
        self._revision = max(self._revision, int(state.revision))
        if self._awaited_revision is not None and self._revision >= self._awaited_revision:
            self._wake()

    def _on_walk(self, data: bytes) -> None:
        self.traffic.count(WALKS_TOPIC, len(data))

    def _on_estimates(self, data: bytes) -> None:
        self.traffic.count(ESTIMATES_TOPIC, len(data))
        message: Any = deserialize_message(data, PoseEstimates)
        source = int(message.source_id)
        if message.run_id == self._run_id and self._walking:
            for one in message.estimates:
                key = (source, int(one.target_id))
                if key in self._walking:
                    self._walked[key] = estimate_from_message(one)
            self._progress()
            if self._walking <= set(self._walked):
                self._wake()
            return
        if message.run_id != self._run_id or source not in self._collecting:
            return
        self._collected[source] = [estimate_from_message(one) for one in message.estimates]
        self._progress()
        if self._collecting <= set(self._collected):
            self._wake()

    async def _on_compute_pose(
        self, request: ComputePose.Request, response: ComputePose.Response
    ) -> ComputePose.Response:
        source, target = int(request.source_id), int(request.target_id)
        problem = None
        if request.policy not in POLICY_NAMES:
            problem = f"unknown policy {request.policy}: expected one of {sorted(POLICY_NAMES)}"
        elif source == target:
            problem = f"source and target are both FLS {source}"
        else:
            for role, fls_id in (("source", source), ("target", target)):
                if fls_id not in self.fls_ids:
                    problem = f"no {role} FLS {fls_id} in this swarm of {len(self.fls_ids)} FLSs"
                    break
                if fls_id in self.departed:
                    problem = f"{role} FLS {fls_id} has departed"
                    break
        if problem is not None:
            response.success, response.message = False, problem
            return response
        result = await self.discover(POLICY_NAMES[request.policy], [source], [target])
        found = [one for one in result.estimates.get(source, []) if one.target == target]
        if not found:
            response.success = False
            response.message = (
                f"FLS {target} is not a blind neighbour of FLS {source}: "
                "Swazure computes poses of blind neighbours only"
                if source in result.estimates
                else f"no answer from source FLS {source}"
            )
            return response
        response.success = True
        response.estimate = estimate_message(source, found[0])
        response.estimate.header.stamp = self.get_clock().now().to_msg()
        return response


def policy_code(policy: str) -> int:
    """The ComputePose/DiscoveryControl code of a policy name."""
    return POLICY_CODES[check_policy(policy)]


__all__ = ["FEWEST_HOPS", "Coordinator", "DiscoveryResult", "MoveResult", "Traffic", "policy_code"]
