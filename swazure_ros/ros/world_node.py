"""The world node: the simulated physics' authority on where FLSs are.

It publishes the positions of every FLS on ``world`` (swazure_interfaces/
WorldState, transient local, so late processes get the newest revision) and
moves FLSs on ``move_commands`` (swazure_interfaces/MoveCommands): a step
aside or a probe puts the FLS at its assigned point plus the displacement, a
return puts it back. The commands of one message are made together, in one
revision.
One world node runs per swarm, in the launcher's process.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from rclpy.context import Context
from swazure_interfaces.msg import MoveCommand, MoveCommands, WorldState

from ..core.errors import UnknownFlsError
from ..sim.replica import WorldReplica
from .convert import array3, world_message
from .names import MOVE_QOS, MOVE_TOPIC, WORLD, WORLD_QOS, WORLD_TOPIC
from .runtime import SwarmNode

FloatArray = NDArray[np.float64]


class WorldNode(SwarmNode):
    """Applies move commands to the world and publishes each new revision."""

    def __init__(
        self, replica: WorldReplica, *, namespace: str = "swarm", context: Context | None = None
    ) -> None:
        super().__init__(WORLD, namespace=namespace, context=context)
        self._replica = replica
        self._publisher = self.create_publisher(WorldState, WORLD_TOPIC, WORLD_QOS)
        self.create_subscription(MoveCommands, MOVE_TOPIC, self._on_moves, MOVE_QOS)
        self.publish_world()

    def publish_world(self) -> None:
        """Publish every FLS's position at the replica's revision."""
        world = self._replica.world
        stamp = self.get_clock().now().to_msg()
        self._publisher.publish(
            world_message(world.revision, world.ids, world.swarm.points, stamp)
        )

    def _on_moves(self, message: MoveCommands) -> None:
        positions = {}
        for command in message.commands:
            target = self._target(command)
            if target is not None:
                positions[int(command.fls_id)] = target
        if positions:
            self._move(positions)

    def _target(self, command: MoveCommand) -> FloatArray | None:
        """Where ``command`` puts its FLS, cm; None (and a warning) for a command to ignore."""
        world = self._replica.world
        try:
            home = world.home.points[world.index(command.fls_id)]
        except UnknownFlsError as err:
            self.get_logger().warning(f"move command ignored: {err}")
            return None
        if command.kind == MoveCommand.KIND_RETURN:
            return np.asarray(home)
        if command.kind in (MoveCommand.KIND_STEP_ASIDE, MoveCommand.KIND_PROBE):
            return np.asarray(home + array3(command.displacement))
        self.get_logger().warning(f"move command ignored: unknown kind {command.kind}")
        return None

    def _move(self, positions: dict[int, FloatArray]) -> None:
        self._replica.apply(self._replica.world.moved(positions))
        self.publish_world()
