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

from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from swazure_interfaces.msg import WorldState

from ..core.observe import NeighbourSets
from ..sim.world import Measurement, World
from .convert import world_positions
from .fls_node import MEASUREMENTS_TOPIC, NEIGHBOURS_SERVICE, FlsNode
from .world_node import WORLD_QOS, WORLD_TOPIC, WorldNode


class WorldReplica:
    """This process's copy of the world; the FLS nodes' camera and radio."""

    def __init__(self, world: World) -> None:
        self.world = world
        self.listeners: list[FlsNode] = []

    def measurement(self, fls_id: int) -> Measurement:
        """What FLS ``fls_id``'s camera measures in the current revision."""
        return self.world.measurement(fls_id)

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbours in the current revision."""
        return self.world.neighbours(fls_id)

    def apply(self, world: World) -> None:
        """Take a newer revision; every local FLS senses anew."""
        if world.revision <= self.world.revision:
            return
        self.world = world
        for node in self.listeners:
            node.sense()

    def apply_state(self, message: WorldState) -> None:
        """Take the world node's positions if they are newer than ours."""
        if message.revision > self.world.revision:
            self.apply(self.world.moved(world_positions(message), revision=message.revision))


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
    ) -> None:
        self.context = context
        self.namespace = namespace.strip("/")
        self.fls_ids = [int(fls_id) for fls_id in fls_ids]
        self.swarm_size = len(world.ids) if swarm_size is None else swarm_size
        self.replica = WorldReplica(world)
        self.executor = EventsExecutor(context=context)
        self.nodes: list[Node] = []
        self.fls_nodes: list[FlsNode] = []
        self.host_node = Node(
            name,
            namespace=self.namespace,
            context=context,
            enable_rosout=False,
            start_parameter_services=False,
        )
        self.host_node.create_subscription(
            WorldState, WORLD_TOPIC, self.replica.apply_state, WORLD_QOS
        )
        self._add(self.host_node)
        if with_world_node:
            self._add(WorldNode(self.replica, namespace=self.namespace, context=context))
        self._service_pattern = re.compile(
            rf"^/{re.escape(self.namespace)}/fls_\d+/{NEIGHBOURS_SERVICE}$"
        )

    def _add(self, node: Node) -> None:
        self.nodes.append(node)
        self.executor.add_node(node)

    def create_fls_nodes(
        self, on_created: Callable[[int], None] | None = None, chunk: int = 25
    ) -> None:
        """Create every FLS node of this process, reporting progress every ``chunk`` nodes."""
        for count, fls_id in enumerate(self.fls_ids, start=1):
            node = FlsNode(fls_id, self.replica, namespace=self.namespace, context=self.context)
            self.fls_nodes.append(node)
            self.replica.listeners.append(node)
            self._add(node)
            if on_created is not None and (count % chunk == 0 or count == len(self.fls_ids)):
                on_created(count)
                # Let discovery and pending callbacks run while we keep creating.
                self.executor.spin_once(timeout_sec=0.0)

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
            self.executor.spin_once(timeout_sec=min(poll, 0.05))
        return False

    def spin_for(self, seconds: float) -> None:
        """Spin every node for ``seconds``."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=min(0.05, max(0.0, deadline - time.monotonic())))

    def close(self) -> None:
        """Destroy every node and the executor."""
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.nodes.clear()
        self.fls_nodes.clear()
        self.replica.listeners.clear()
        self.executor.shutdown()

    def __enter__(self) -> SwarmHost:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
