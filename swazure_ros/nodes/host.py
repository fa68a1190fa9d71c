"""Hosting part of a swarm in one process: the world replica, the nodes, one executor.

A swarm may be split over several processes. Each builds the same world from
the same :class:`~swazure_ros.sim.world.WorldSpec`, hosts the FLS nodes of its
share of ids, follows the world node's revisions through a small host node,
and spins every node on one EventsExecutor (the stock executors rebuild a wait
set over every entity on each spin, which does not scale to a thousand nodes).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable, Sequence
from typing import TypeVar

from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future
from swazure_interfaces.msg import (
    DiscoveryControl,
    PathOffer,
    PathWalk,
    RoundAck,
    TrackRequest,
    TrackSample,
    WorldState,
)
from swazure_interfaces.srv import ComputePose

from ..core.discovery import LocalView
from ..core.errors import UnknownFlsError
from ..core.motion import FloatArray, Motion
from ..core.observe import NeighbourSets
from ..core.tracking import choose_relay, next_relay, relay_sample
from ..sim.world import Measurement, World
from .convert import offer_from_message, world_positions
from .fls_node import (
    COMPUTE_POSE_SERVICE,
    MEASUREMENTS_TOPIC,
    NEIGHBOURS_SERVICE,
    RADIO_TOPIC,
    ROUND_QOS,
    TRACK_REQUESTS_TOPIC,
    TRACK_SAMPLES_TOPIC,
    FlsNode,
)
from .world_node import WORLD_QOS, WORLD_TOPIC, WorldNode

_Result = TypeVar("_Result")


class WorldReplica:
    """This process's copy of the world; the FLS nodes' camera and radio.

    FLSs with a trajectory in ``motion`` fly it on the ROS clock (simulated
    time in a track run) from where the world revision puts them.
    """

    def __init__(self, world: World, motion: Motion | None = None) -> None:
        self.world = world
        self.motion = motion or Motion()
        self.listeners: list[FlsNode] = []
        self.on_revision: list[Callable[[], None]] = []  # called after each new revision

    def measurement(self, fls_id: int) -> Measurement:
        """What FLS ``fls_id``'s camera measures in the current revision."""
        return self.world.measurement(fls_id)

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbours in the current revision."""
        return self.world.neighbours(fls_id)

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours in the current revision."""
        return self.world.view(fls_id)

    @property
    def sweet_min(self) -> float:
        """Shortest sweet tracking distance of the sensor, cm."""
        return self.world.sensor.sweet_min

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        return self.world.id_space

    def _at(self, seconds: float, sensing: Callable[..., _Result], *fls_ids: int) -> _Result:
        """``sensing(sensor, points, radius, *rows)`` with every FLS where it is at ``seconds``."""
        world = self.world
        points = self.motion.points(world.swarm.points, world.ids, seconds)
        rows = (world.index(fls_id) for fls_id in fls_ids)
        return sensing(world.sensor, points, world.swarm.radius, *rows)

    def _fls_id(self, row: int | None) -> int | None:
        return None if row is None else int(self.world.ids[row])

    def choose_relay(self, source: int, target: int, seconds: float) -> int | None:
        """The relay FLS for ``source`` to track ``target`` at ``seconds``, or None."""
        return self._fls_id(self._at(seconds, choose_relay, source, target))

    def next_relay(self, source: int, target: int, relay: int, seconds: float) -> int | None:
        """The relay to hand ``relay``'s stream over to at ``seconds``, or None."""
        return self._fls_id(self._at(seconds, next_relay, source, target, relay))

    def track_sample(
        self, source: int, relay: int, target: int, seconds: float
    ) -> tuple[int, FloatArray]:
        """(RELAY_* status, (3,) cm) of what ``relay`` senses for ``source`` at ``seconds``."""
        return self._at(seconds, relay_sample, source, relay, target)

    def apply(self, world: World) -> None:
        """Take a newer revision; the local FLSs sense anew when next asked."""
        if world.revision <= self.world.revision:
            return
        self.world = world
        for node in self.listeners:
            node.sense()
        for hook in self.on_revision:
            hook()

    def apply_state(self, message: WorldState) -> None:
        """Take the world node's positions if they are newer than ours."""
        if message.revision > self.world.revision:
            self.apply(self.world.moved(world_positions(message), revision=message.revision))


CONTROL_TOPIC = "discovery"
ACK_TOPIC = "round_acks"
WALKS_TOPIC = "path_walks"


class Radio:
    """The radio medium and round clock of one process (docs/protocol.md).

    It hears every broadcast on ``radio`` once and hands it to the local FLS
    nodes within radio range of the sender, as a real radio would; it hands
    the coordinator's control messages to every local FLS; and once it has
    delivered every offer of a round, it acknowledges the round on
    ``round_acks`` so that the coordinator can open the next one. Path walks
    on ``path_walks`` go to the FLS they are addressed to, once this process
    has the world revision they must be measured in; track requests go to
    their relay and track samples to their source.
    """

    def __init__(self, node: Node, replica: WorldReplica, fls_nodes: dict[int, FlsNode]) -> None:
        self._node = node
        self._replica = replica
        self._fls = fls_nodes
        self._departed: dict[int, frozenset[int]] = {}
        self._first_round: dict[int, int] = {}
        self._rounds: dict[tuple[int, int], DiscoveryControl] = {}  # (run, round) -> ROUND
        self._heard: dict[tuple[int, int], int] = {}
        self._acks = node.create_publisher(RoundAck, ACK_TOPIC, ROUND_QOS)
        node.create_subscription(DiscoveryControl, CONTROL_TOPIC, self._on_control, ROUND_QOS)
        node.create_subscription(PathOffer, RADIO_TOPIC, self._on_offer, ROUND_QOS)
        # One walk publisher per process, not per FLS: a thousand more endpoints
        # would slow the swarm's discovery for a message few FLSs ever send.
        self._walks = node.create_publisher(PathWalk, WALKS_TOPIC, ROUND_QOS)
        self._early_walks: list[PathWalk] = []
        node.create_subscription(PathWalk, WALKS_TOPIC, self._on_walk, ROUND_QOS)
        replica.on_revision.append(self._take_early_walks)
        node.create_subscription(
            TrackRequest, TRACK_REQUESTS_TOPIC, self._on_track_request, ROUND_QOS
        )
        node.create_subscription(
            TrackSample, TRACK_SAMPLES_TOPIC, self._on_track_sample, ROUND_QOS
        )

    def _on_track_request(self, request: TrackRequest) -> None:
        node = self._fls.get(int(request.relay_id))
        if node is not None:
            node.on_track_request(request)

    def _on_track_sample(self, sample: TrackSample) -> None:
        node = self._fls.get(int(sample.source_id))
        if node is not None:
            node.on_track_sample(sample)

    def _on_control(self, control: DiscoveryControl) -> None:
        run = control.run_id
        if control.command == DiscoveryControl.COMMAND_START:
            self._departed[run] = frozenset(int(fls) for fls in control.departed_ids)
            self._first_round[run] = control.round
            for key in [key for key in self._heard if key[0] == run]:
                del self._heard[key]
        departed = self._departed.get(run, frozenset())
        for fls_id, node in list(self._fls.items()):
            if fls_id not in departed:
                node.on_control(control, departed)
        if control.command == DiscoveryControl.COMMAND_ROUND:
            self._rounds[(run, control.round)] = control
            self._acknowledge(run, control.round)
        elif control.command == DiscoveryControl.COMMAND_END:
            self._forget(run)

    def _on_offer(self, message: PathOffer) -> None:
        run, round_ = message.run_id, message.round
        if round_ < self._first_round.get(run, 0):
            return  # from before a restart of the phase
        departed = self._departed.get(run, frozenset())
        sender = int(message.sender_id)
        if sender not in departed:
            offer = offer_from_message(message)
            for fls_id in self._replica.world.in_range(sender).tolist():
                node = self._fls.get(fls_id)
                if node is not None and fls_id not in departed:
                    node.on_offer(run, sender, offer)
        self._heard[(run, round_)] = self._heard.get((run, round_), 0) + 1
        self._acknowledge(run, round_)

    def _on_walk(self, walk: PathWalk) -> None:
        node = self._fls.get(int(walk.path[walk.hop])) if len(walk.path) else None
        if node is None:
            return  # another process's FLS, or a stopped one
        if walk.revision > self._replica.world.revision:
            self._early_walks.append(walk)
            return
        onward = node.on_walk(walk)
        if onward is not None:
            onward.header.stamp = self._node.get_clock().now().to_msg()
            self._walks.publish(onward)

    def _take_early_walks(self) -> None:
        early, self._early_walks = self._early_walks, []
        for walk in early:
            self._on_walk(walk)

    def _acknowledge(self, run: int, round_: int) -> None:
        control = self._rounds.get((run, round_))
        heard = self._heard.get((run, round_), 0)
        if control is None or heard < control.expected:
            return
        del self._rounds[(run, round_)]
        ack = RoundAck(run_id=run, phase=control.phase, round=round_, heard=heard)
        ack.host = self._node.get_name()
        ack.header.stamp = self._node.get_clock().now().to_msg()
        self._acks.publish(ack)

    def _forget(self, run: int) -> None:
        self._departed.pop(run, None)
        self._first_round.pop(run, None)
        for table in (self._rounds, self._heard):
            for key in [key for key in table if key[0] == run]:
                del table[key]


class SwarmHost:
    """The nodes of one process of a swarm, spun by one EventsExecutor."""

    def __init__(
        self,
        world: World,
        fls_ids: Sequence[int],
        *,
        context: Context,
        namespace: str = "swarm",
        swarm_size: int | None = None,
        with_world_node: bool = True,
        name: str = "host_0",
        motion: Motion | None = None,
        parameters: dict[str, object] | None = None,
    ) -> None:
        self.context = context
        self.namespace = namespace.strip("/")
        self.fls_ids = [int(fls_id) for fls_id in fls_ids]
        self.swarm_size = len(world.ids) if swarm_size is None else swarm_size
        self.replica = WorldReplica(world, motion)
        # Given to every FLS node over any parameter file, e.g. use_sim_time for a
        # simulated clock (nodes.clock) or a track run's track.* settings.
        self._overrides = [
            Parameter(name, value=value) for name, value in (parameters or {}).items()
        ]
        self.executor = EventsExecutor(context=context)
        self._spinning = False
        self._stop_requested = False
        self.nodes: list[Node] = []
        self.fls_nodes: list[FlsNode] = []
        self.fls_by_id: dict[int, FlsNode] = {}
        self.host_node = Node(
            name,
            namespace=self.namespace,
            context=context,
            enable_rosout=False,
            start_parameter_services=False,
        )
        self.host_node.create_subscription(WorldState, WORLD_TOPIC, self._on_world, WORLD_QOS)
        self.radio = Radio(self.host_node, self.replica, self.fls_by_id)
        # One client per process, shared by its FLS nodes' compute_pose services.
        self._coordinator = self.host_node.create_client(
            ComputePose, f"coordinator/{COMPUTE_POSE_SERVICE}"
        )
        self._add(self.host_node)
        if with_world_node:
            self._add(WorldNode(self.replica, namespace=self.namespace, context=context))
        self._service_pattern = re.compile(
            rf"^/{re.escape(self.namespace)}/fls_\d+/{NEIGHBOURS_SERVICE}$"
        )

    def _on_world(self, message: WorldState) -> None:
        try:
            self.replica.apply_state(message)
        except UnknownFlsError as err:
            # Another swarm's world node on this ROS domain: ours must keep running.
            self.host_node.get_logger().error(
                f"ignored world revision {message.revision}: {err}; is another swarm "
                "running on this ROS_DOMAIN_ID?",
                throttle_duration_sec=10.0,
            )

    def add(self, node: Node) -> None:
        """Spin ``node`` with this process's nodes; :meth:`close` destroys it."""
        self._add(node)

    def _add(self, node: Node) -> None:
        self.nodes.append(node)
        self.executor.add_node(node)

    def ask_coordinator(self, request: ComputePose.Request) -> Future:
        """Pass an FLS's ComputePose request on to the coordinator: a future of its answer."""
        if self._coordinator.service_is_ready():
            return self._coordinator.call_async(request)
        unreachable = Future()
        unreachable.set_result(
            ComputePose.Response(
                success=False,
                message=f"the coordinator's {self._coordinator.srv_name} is not reachable",
            )
        )
        return unreachable

    def create_fls_nodes(
        self, on_created: Callable[[int], None] | None = None, chunk: int = 25
    ) -> None:
        """Create every FLS node of this process, reporting progress every ``chunk`` nodes."""
        for count, fls_id in enumerate(self.fls_ids, start=1):
            node = FlsNode(
                fls_id,
                self.replica,
                namespace=self.namespace,
                context=self.context,
                ask_coordinator=self.ask_coordinator,
                parameter_overrides=self._overrides,
            )
            self.fls_nodes.append(node)
            self.fls_by_id[fls_id] = node
            self.replica.listeners.append(node)
            self._add(node)
            if on_created is not None and (count % chunk == 0 or count == len(self.fls_ids)):
                on_created(count)
                # Let discovery and pending callbacks run while we keep creating.
                self.spin_once(0.0)

    def stop_fls(self, fls_id: int) -> None:
        """Destroy FLS ``fls_id``'s node, as if its software stopped; its body stays."""
        node = self.fls_by_id.pop(fls_id)
        self.fls_nodes.remove(node)
        self.replica.listeners.remove(node)
        self.nodes.remove(node)
        self.executor.remove_node(node)
        node.destroy_node()

    def discovered(self) -> tuple[int, int]:
        """(measurement publishers, neighbour services) of the swarm this process sees."""
        topic = f"/{self.namespace}/{MEASUREMENTS_TOPIC}"
        publishers = self.host_node.count_publishers(topic)
        services = sum(
            1
            for name, _ in self.host_node.get_service_names_and_types()
            if self._service_pattern.match(name)
        )
        return publishers, services

    def is_discovered(self) -> bool:
        """True when every FLS node of the whole swarm is visible from this process."""
        publishers, services = self.discovered()
        return publishers >= self.swarm_size and services >= self.swarm_size

    def spin_until_discovered(
        self, timeout: float, poll: float = 0.25, on_poll: Callable[[int, int], None] | None = None
    ) -> bool:
        """Spin until :meth:`is_discovered` or ``timeout`` seconds; return whether discovered."""
        deadline = time.monotonic() + timeout
        next_poll = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_poll:
                publishers, services = self.discovered()
                if on_poll is not None:
                    on_poll(publishers, services)
                if publishers >= self.swarm_size and services >= self.swarm_size:
                    return True
                next_poll = time.monotonic() + poll
            self.spin_once(min(poll, 0.05))
        return False

    def spin_once(self, timeout: float) -> None:
        """Spin once, for at most ``timeout`` s; a stop that came meanwhile is raised after it."""
        self._spinning = True
        try:
            self.executor.spin_once(timeout_sec=timeout)
        finally:
            self._spinning = False
        if self._stop_requested:
            self._stop_requested = False
            raise KeyboardInterrupt

    def defer_stop(self) -> bool:
        """For a signal handler: if a spin is under way, stop after it and return True.

        A KeyboardInterrupt raised inside a node's callback would be reported by
        the executor as that callback's failure; raised after the spin, it is a
        plain stop.
        """
        if self._spinning:
            self._stop_requested = True
        return self._spinning

    def spin_for(self, seconds: float) -> None:
        """Spin every node for ``seconds``."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.spin_once(min(0.05, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Destroy every node and the executor."""
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.nodes.clear()
        self.fls_nodes.clear()
        self.fls_by_id.clear()
        self.replica.listeners.clear()
        self.executor.shutdown()

    def __enter__(self) -> SwarmHost:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
