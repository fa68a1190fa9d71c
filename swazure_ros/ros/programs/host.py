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
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from functools import partial

from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from swazure_interfaces.msg import (
    WorldState,
)
from swazure_interfaces.srv import GetNeighbours

from ...core.motion import Motion
from ...protocol.radio_loss import RadioLoss
from ...protocol.readings import ReadingsBook
from ...protocol.rounds import Absences
from ...sim.replica import WorldReplica
from ...sim.world import World
from ..convert.sensing import world_positions
from ..nodes.fls_node import FlsNode, RadioLink, Transmitter
from ..nodes.radio import Radio
from ..nodes.world_node import WorldNode
from ..plumbing.liveness import FlsLiveness
from ..plumbing.names import (
    COORDINATOR,
    LIVENESS_GRACE,
    MEASUREMENTS_TOPIC,
    NEIGHBOURS_SERVICE,
    WORLD_QOS,
    WORLD_REACH,
    WORLD_TOPIC,
    fls_id_of,
)
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterError
from ..plumbing.shared_timers import SharedTimers
from ..security.auth import SwarmKey
from ..security.guard import Guard, check

#: Seconds between a host's looks at the graph for its coordinator.
COORDINATOR_WATCH_PERIOD = 0.5


@dataclass(frozen=True)
class HostConfig:
    """What one process of a swarm hosts: its share of FLS ids, names, parameters and key.

    ``swarm_size`` None: the world's FLSs. ``parameters`` go to every FLS node
    over any parameter file (use_sim_time for a simulated clock, a track run's
    track.* settings); ``fls_parameters`` to one FLS, over those. With
    ``parameter_services`` every FLS node answers ``ros2 param``: six services
    more a node. With ``fls_services`` False no FLS node offers
    ``get_neighbours``: the host node's answers for each (its two endpoints
    instead of two an FLS, whose discovery grows with the square of their
    number in a process; docs/swarm.md).
    """

    fls_ids: tuple[int, ...]
    namespace: str = "swarm"
    swarm_size: int | None = None
    with_world_node: bool = True
    name: str = "host_0"
    parameters: Mapping[str, object] = field(default_factory=dict)
    fls_parameters: Mapping[int, Mapping[str, object]] = field(default_factory=dict)
    key: SwarmKey | None = None
    parameter_services: bool = False
    fls_services: bool = True


class SwarmHost:
    """The nodes of one process of a swarm, spun by one EventsExecutor."""

    def __init__(
        self,
        world: World,
        config: HostConfig,
        *,
        context: Context,
        motion: Motion | None = None,
    ) -> None:
        self.context = context
        self.config = config
        self.namespace = config.namespace.strip("/")
        self.parameter_services = config.parameter_services
        self.fls_ids = [int(fls_id) for fls_id in config.fls_ids]
        self.swarm_size = len(world.ids) if config.swarm_size is None else config.swarm_size
        self.replica = WorldReplica(world, motion)
        self._overrides = [
            Parameter(name, value=value) for name, value in config.parameters.items()
        ]
        # One FLS's own parameters, after (so over) every FLS's.
        self._fls_overrides = {
            int(fls_id): [Parameter(name, value=value) for name, value in own.items()]
            for fls_id, own in config.fls_parameters.items()
        }
        self.executor = EventsExecutor(context=context)
        self._spinning = False
        self._stop_requested = False
        self.nodes: list[Node] = []
        # Removed and waiting for the executor's turn that destroys them (remove).
        self._leaving: list[Node] = []
        self.fls_nodes: list[FlsNode] = []
        self.fls_by_id: dict[int, FlsNode] = {}
        self.host_node = SwarmNode(config.name, namespace=self.namespace, context=context)
        self.guard = Guard(self.host_node, config.key)
        self.guard.subscribe(WorldState, WORLD_TOPIC, self._on_world, WORLD_QOS)
        # Before the radio's hook: walks that waited for a revision measure it afresh.
        self.replica.on_revision.append(self._sense_anew)
        # What the radio hears of the FLSs' cameras, for its FLSs' fits: one book a process.
        self.readings = ReadingsBook()
        self.radio = self._make_radio()
        # The coordinator's liveness, from the graph like the FLSs' (Coordinator._on_liveness).
        self._coordinator_seen = False
        self.aborted = 0  # ABORTED estimates sent after the coordinator was lost
        # Only an FLS once seen can go missing: remote ones join the graph late.
        self._liveness = FlsLiveness(self.host_node, self.namespace, LIVENESS_GRACE)
        self._coordinator_absent = Absences(LIVENESS_GRACE)
        self._controls_at_loss = 0
        self.host_node.create_timer(COORDINATOR_WATCH_PERIOD, self._watch_graph)
        self.transmitter = Transmitter(self.host_node, self.guard.key)
        # What every FLS node here sends by and hears through: the process's radio. Their
        # frames run on one timer of the host's node (shared_timers); on a simulated
        # clock, which the host node does not follow, each on a timer of its own.
        own_clocks = bool(config.parameters.get("use_sim_time", False))
        self.frames = None if own_clocks else SharedTimers(self.host_node)
        self._link = RadioLink(self.transmitter, self.readings, self.guard.key, self.frames)
        # One /parameter_events writer for the process's FLS nodes (SwarmNode).
        self._parameter_events = self.host_node.create_parameter_events_publisher()
        self._add(self.host_node)
        if self.fls_ids:
            self.host_node.create_service(
                GetNeighbours, f"~/{NEIGHBOURS_SERVICE}", self._on_get_neighbours
            )
        #: The world node, on the host that holds the world.
        self.world_node: WorldNode | None = None
        if config.with_world_node:
            self.world_node = WorldNode(
                self.replica, namespace=self.namespace, context=context, key=config.key
            )
            self._add(self.world_node)
        self._measurements_topic = f"/{self.namespace}/{MEASUREMENTS_TOPIC}"
        self._service_pattern = re.compile(
            rf"^/{re.escape(self.namespace)}/fls_\d+/{NEIGHBOURS_SERVICE}$"
        )

    def _make_radio(self) -> Radio | None:
        """The process's radio; none in a process of no FLS (the simulator beside FLSs that
        run one to a process): it relays nothing, and the coordinator counts no host here."""
        if not self.fls_ids:
            return None
        return Radio(
            self.host_node,
            self.replica,
            self.fls_by_id,
            self._radio_loss(),
            self.guard,
            readings=self.readings,
            local=self.fls_ids,
        )

    def _radio_loss(self) -> RadioLoss | None:
        """The simulated radio's loss and delay, from this host node's parameters (radio.*)."""
        node = self.host_node
        try:
            probability = node.declare_parameter("radio.loss", 0.0).value
            seed = node.declare_parameter("radio.seed", 0).value
            attempts = node.declare_parameter("radio.attempts", RadioLoss.attempts).value
            delay = node.declare_parameter("radio.delay", 0.0).value
            return RadioLoss(float(probability), int(seed), int(attempts), float(delay))
        except (ParameterException, TypeError, ValueError) as err:
            raise ParameterError(f"{node.get_fully_qualified_name()}: radio: {err}") from err

    def _watch_graph(self) -> None:
        """Liveness from the graph: FLS nodes gone (replica.gone), and the coordinator."""
        namespace = self._liveness.namespace
        if self._liveness.due():  # a large swarm's graph is looked at less often
            self.replica.gone |= self._liveness.look(self.replica.gone)
            self.replica.gone -= self._liveness.back
        nodes = self._liveness.nodes
        now = time.monotonic()
        if self.radio is None:
            return  # no FLS here to abort a run for
        # The coordinator as -1 among the absences: it must stay away as long.
        # Remote nodes reach the graph through each participant's node list, which can
        # lag or flap while the participant itself is fine: a coordinator still heard
        # clocking rounds is there, whatever the list says.
        heard_lately = now - self.radio.last_control_at < LIVENESS_GRACE
        present = (COORDINATOR, namespace) in nodes or heard_lately
        # Seen on the graph, or heard: a run can start and end between two looks.
        self._coordinator_seen |= self.radio.controls_heard > self._controls_at_loss
        if present or not self._coordinator_seen:
            self._coordinator_seen = self._coordinator_seen or present
            self._coordinator_absent.gone(set(), now)
            return
        if self._coordinator_absent.gone({-1}, now):
            self._coordinator_seen = False
            self._controls_at_loss = self.radio.controls_heard
            self.aborted += self.radio.coordinator_lost()

    def _sense_anew(self) -> None:
        # An FLS senses a revision when asked; its frames need waking only for a reader.
        if self.host_node.count_subscribers(self._measurements_topic):
            for node in self.fls_nodes:
                node.sense()

    def _on_get_neighbours(
        self, request: GetNeighbours.Request, response: GetNeighbours.Response
    ) -> GetNeighbours.Response:
        # Any FLS of this process, as the FLS's own service answers (FlsNode.answer_neighbours).
        node = self.fls_by_id.get(request.fls_id)
        if node is not None:
            return node.answer_neighbours(response)
        response.success = False
        name = self.host_node.get_fully_qualified_name()
        response.message = (
            f"{name} answers for the FLSs of its process: name one (fls_id)"
            if request.fls_id == GetNeighbours.Request.THIS_FLS
            else f"{name} does not host FLS {request.fls_id}: another host does, if it exists"
        )
        return response

    def _on_world(self, message: WorldState) -> None:
        # Another swarm's world node on this ROS domain, or a forgery: dropped by the guard.
        world = self.replica.world
        ids, points = world_positions(message, world.ids, WORLD_REACH)
        check(message.revision < 2**63, f"revision {message.revision} out of range")
        self.replica.apply_positions(int(message.revision), ids, points)

    def add(self, node: Node) -> None:
        """Spin ``node`` with this process's nodes; :meth:`close` destroys it."""
        self._add(node)

    def _add(self, node: Node) -> None:
        self.nodes.append(node)
        self.executor.add_node(node)

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
                link=self._link,
                camera=partial(self.replica.camera_image, fls_id),
                relay_senses=lambda: self.replica.relay_senses,
                parameter_overrides=[*self._overrides, *self._fls_overrides.get(fls_id, [])],
                parameter_services=self.parameter_services,
                parameter_events=self._parameter_events,
            )
            if self.config.fls_services:
                node.offer_neighbours_service()
            self.fls_nodes.append(node)
            self.fls_by_id[fls_id] = node
            self._liveness.seen.add(fls_id)  # on this participant's graph from now on
            self._add(node)
            if on_created is not None and (count % chunk == 0 or count == len(self.fls_ids)):
                on_created(count)
                # Let discovery and pending callbacks run while we keep creating.
                self.spin_once(0.0)

    def stop_fls(self, fls_id: int) -> None:
        """Destroy FLS ``fls_id``'s node, as if its software stopped; its body stays."""
        node = self.fls_by_id.pop(fls_id)
        self.fls_nodes.remove(node)
        self.remove(node)

    def remove(self, node: Node) -> None:
        """Stop spinning ``node`` and destroy it at the executor's next turn, mid-run or not.

        The EventsExecutor runs what a removed node's timers and subscriptions queued
        before the removal: destroyed at once, the node would meet its own callbacks
        afterwards and fail them with InvalidHandle (the faults bench lost its
        coordinator so). Destroyed by a task queued behind them, it runs them first.
        """
        self.nodes.remove(node)
        self.executor.remove_node(node)
        self._leaving.append(node)

        def destroy() -> None:
            self._leaving.remove(node)
            node.destroy_node()

        self.executor.create_task(destroy)

    def unreached(self) -> list[int]:
        """The FLSs of the swarm whose endpoints this process does not all see, by id.

        Their neighbour services, or where hosts answer for them (``fls_services``
        False), their measurement publishers.
        """
        if self.config.fls_services:
            names = [name.rsplit("/", 2)[-2] for name in self._fls_service_names()]
        else:
            infos = self.host_node.get_publishers_info_by_topic(self._measurements_topic)
            names = [info.node_name for info in infos]
        seen = {fls_id for name in names if (fls_id := fls_id_of(name)) is not None}
        return [int(fls_id) for fls_id in self.replica.ids.tolist() if fls_id not in seen]

    def _fls_service_names(self) -> list[str]:
        return [
            name
            for name, _ in self.host_node.get_service_names_and_types()
            if self._service_pattern.match(name)
        ]

    def publishers_seen(self) -> int:
        """The swarm's measurement publishers this process sees (one per FLS node)."""
        return self.host_node.count_publishers(self._measurements_topic)

    def services_seen(self) -> int:
        """The FLSs' own neighbour services this process sees; 0 where hosts answer for
        them (none to see)."""
        return len(self._fls_service_names()) if self.config.fls_services else 0

    def discovered(self) -> tuple[int, int]:
        """(measurement publishers, neighbour services) of the swarm this process sees."""
        return self.publishers_seen(), self.services_seen()

    def is_discovered(self) -> bool:
        """True when every FLS node of the whole swarm is visible from this process."""
        # The publishers first: counting one topic's is cheap; listing the graph's every
        # service is not (a hundred FLS processes offer 700, each name taken apart at
        # each look), and the launcher looks 20 times a second while it waits.
        publishers = self.publishers_seen()
        return publishers >= self.swarm_size and self._complete(publishers, self.services_seen())

    def _complete(self, publishers: int, services: int) -> bool:
        return publishers >= self.swarm_size and (
            services >= self.swarm_size or not self.config.fls_services
        )

    def discovery_text(self) -> str:
        """What this process sees of the swarm, for a message: ``3 of 5 FLS publishers ...``."""
        publishers, services = self.discovered()
        seen = f"{publishers} of {self.swarm_size} FLS publishers"
        return f"{seen} and {services} services" if self.config.fls_services else seen

    def spin_until_discovered(self, timeout: float, poll: float = 0.25) -> bool:
        """Spin until :meth:`is_discovered` or ``timeout`` seconds; return whether discovered."""
        deadline = time.monotonic() + timeout
        next_poll = 0.0
        while time.monotonic() < deadline:
            if time.monotonic() >= next_poll:
                if self.is_discovered():
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
        """Destroy every node, those removed but not yet destroyed too, and the executor."""
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        # Nothing spins after this: a removed node's destroying task would never run.
        for node in self._leaving:
            node.destroy_node()
        self._leaving.clear()
        self.nodes.clear()
        self.fls_nodes.clear()
        self.fls_by_id.clear()
        self.executor.shutdown()

    def __enter__(self) -> SwarmHost:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
