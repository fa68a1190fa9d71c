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
from rclpy.context import Context
from swazure_interfaces.msg import MoveCommand, MoveCommands, WorldState

from ..sim.replica import WorldReplica
from .auth import SwarmKey
from .convert import moves_from_message, stamp_nanoseconds, world_message
from .guard import Guard, check
from .names import MOVE_QOS, MOVE_TOPIC, WORLD, WORLD_QOS, WORLD_REACH, WORLD_TOPIC
from .runtime import SwarmNode


class WorldNode(SwarmNode):
    """Applies move commands to the world and publishes each new revision."""

    def __init__(
        self,
        replica: WorldReplica,
        *,
        namespace: str = "swarm",
        context: Context | None = None,
        key: SwarmKey | None = None,
    ) -> None:
        super().__init__(WORLD, namespace=namespace, context=context)
        self._replica = replica
        self._publisher = self.create_publisher(WorldState, WORLD_TOPIC, WORLD_QOS)
        self.guard = Guard(self, key)
        self._last_stamp = 0  # ns, of the newest batch of moves taken
        self.guard.subscribe(MoveCommands, MOVE_TOPIC, self._on_moves, MOVE_QOS)
        self.publish_world()

    def publish_world(self) -> None:
        """Publish every FLS's position at the replica's revision."""
        world = self._replica.world
        stamp = self.get_clock().now().to_msg()
        message = world_message(world.revision, world.ids, world.swarm.points, stamp)
        self._publisher.publish(self.guard.key.serialize(message))

    def _on_moves(self, message: MoveCommands) -> None:
        world = self._replica.world
        ids, kinds, displacement = moves_from_message(message, world.ids, WORLD_REACH)
        # The coordinator stamps its batches in order: an older one is a replay.
        stamp = stamp_nanoseconds(message.header.stamp)
        check(stamp >= self._last_stamp, "older than the last batch of moves (a replay?)")
        self._last_stamp = stamp
        if not len(ids):
            return
        rows = world.indices(ids)
        aside = kinds != MoveCommand.KIND_RETURN
        # A step aside or a probe: home plus the displacement; a return: home.
        targets = world.home.points[rows] + np.where(aside[:, None], displacement, 0.0)
        self._replica.apply(world.placed(ids, targets))
        self.publish_world()
