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

from collections.abc import Sequence

from rclpy.context import Context
from rclpy.node import Node
from swazure_interfaces.msg import Detections, MoveCommands, WorldState
from tf2_msgs.msg import TFMessage

from ...protocol.moves import commanded_points
from ...protocol.senses import carried_markers
from ...sim.replica import WorldReplica
from ...sim.world import WorldSpec
from ..convert.discovery import moves_from_message
from ..convert.sensing import FlsFrames, detections_message, world_message
from ..convert.units import stamp_nanoseconds
from ..plumbing.names import (
    CAMERAS,
    DETECTIONS_QOS,
    DETECTIONS_TOPIC,
    MOVE_QOS,
    MOVE_TOPIC,
    TF_STATIC_QOS,
    TF_STATIC_TOPIC,
    WORLD,
    WORLD_QOS,
    WORLD_REACH,
    WORLD_TOPIC,
    node_name,
)
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterSpec
from ..plumbing.process import run_process
from ..plumbing.startup import (
    DESCRIPTION_PARAMETERS,
    KEY_FILE,
    NAMESPACE,
    SWARM_INSTANCE,
    StartupValues,
    declare_startup,
    description_from,
    program_help,
)
from ..security.auth import SwarmKey
from ..security.guard import Guard, check
from .instance import Announcer, program_key


class WorldNode(SwarmNode):
    """Applies move commands to the world and publishes each new revision."""

    def __init__(
        self,
        replica: WorldReplica,
        *,
        namespace: str = "swarm",
        context: Context | None = None,
        key: SwarmKey | None = None,
        parameter_services: bool = False,
    ) -> None:
        super().__init__(
            WORLD, namespace=namespace, context=context, parameter_services=parameter_services
        )
        self._replica = replica
        self._publisher = self.create_publisher(WorldState, WORLD_TOPIC, WORLD_QOS)
        # Where every FLS is, for RViz, Foxglove and tf2 listeners: a frame per FLS.
        self._frames = self.create_publisher(TFMessage, TF_STATIC_TOPIC, TF_STATIC_QOS)
        self._frame_message = FlsFrames(replica.world.ids)
        self.guard = Guard(self, key)
        self._last_stamp = 0  # ns, of the newest batch of moves taken
        self.guard.subscribe(MoveCommands, MOVE_TOPIC, self._on_moves, MOVE_QOS)
        if self.guard.key.active:
            # Hosts that share a key file take the swarm's instance from here.
            self.announcer = Announcer(self, self.guard.key)
        self.publish_world()

    def publish_world(self) -> None:
        """Publish every FLS's position at the replica's revision."""
        world = self._replica.world
        stamp = self.get_clock().now().to_msg()
        message = world_message(world.revision, world.ids, world.swarm.points, stamp)
        self._publisher.publish(self.guard.key.serialize(message))
        self._frames.publish(self._frame_message.serialized(world.swarm.points, stamp))

    def _on_moves(self, message: MoveCommands) -> None:
        world = self._replica.world
        ids, kinds, displacement = moves_from_message(message, world.ids, WORLD_REACH)
        # The coordinator stamps its batches in order: an older one is a replay.
        stamp = stamp_nanoseconds(message.header.stamp)
        check(stamp >= self._last_stamp, "older than the last batch of moves (a replay?)")
        self._last_stamp = stamp
        if not len(ids):
            return
        targets = commanded_points(world.home.points[world.indices(ids)], kinds, displacement)
        self._replica.apply(world.placed(ids, targets))
        self.publish_world()


class SimulatedCameras(SwarmNode):
    """The simulated camera of each FLS that runs in a process of its own.

    For every FLS of ``fls_ids`` it publishes what the FLS's camera reads on
    ``fls_<id>/camera/detections`` (swazure_interfaces/Detections, latched),
    at the start, after each new world revision and every ``frame_period``
    seconds, as an ArUco detector on the FLS's camera streams its frames.
    """

    def __init__(
        self,
        replica: WorldReplica,
        fls_ids: Sequence[int],
        *,
        namespace: str = "swarm",
        context: Context | None = None,
        frame_period: float = 1.0,
        key: SwarmKey | None = None,
    ) -> None:
        super().__init__(CAMERAS, namespace=namespace, context=context)
        self._replica = replica
        # Signed: a detection no process of the swarm made never enters an FLS's view.
        self._key = key or SwarmKey()
        self._detections = {
            int(fls_id): self.create_publisher(
                Detections, f"{node_name(int(fls_id))}/{DETECTIONS_TOPIC}", DETECTIONS_QOS
            )
            for fls_id in fls_ids
        }
        replica.on_revision.append(self.publish_frames)
        self.publish_frames()
        # A stream, not only the latched last frame: an FLS process that joined while
        # its frame was being sent sometimes never got it (2 of 25 in one bring-up of
        # 2026-11-26, over UDP; more over shared memory), and would never join the swarm.
        self.create_timer(frame_period, self.publish_frames)

    def publish_frames(self) -> None:
        """Publish every FLS's detections in the replica's revision."""
        world = self._replica.world
        markers = carried_markers(world.sensor, world.ids)
        stamp = self.get_clock().now().to_msg()
        for fls_id, publisher in self._detections.items():
            seen = self._replica.measurement(fls_id)
            markers_seen = markers[world.indices(seen.target_ids)]
            message = detections_message(
                fls_id, seen, markers_seen, world.sensor, stamp, world.revision
            )
            publisher.publish(self._key.serialize(message))


CAMERAS_FLAG = ParameterSpec(
    "cameras", True, "publish every FLS's detections, for FLSs that run one to a process"
)
#: What the program takes as arguments, before it builds its nodes.
STARTUP = (NAMESPACE, KEY_FILE, SWARM_INSTANCE, CAMERAS_FLAG, *DESCRIPTION_PARAMETERS)
USAGE = program_help(
    "world",
    """The simulator of a swarm whose FLSs run one to a process: the world node (where
every FLS is; it applies the heuristics' moves) and every FLS's simulated camera,
which publishes the FLS's ArUco detections on /NAMESPACE/fls_<id>/camera/detections.

  ros2 run swazure_ros world --cloud torus:120 --scale 5 --beta 0.5""",
    STARTUP,
)


def build_world(context: Context, values: StartupValues) -> list[Node]:
    """The simulator's process: the world node, and the cameras of FLSs in their own processes.

    ``values`` (STARTUP): the swarm's description (``cloud``, ``beta`` or ``radius``,
    ...), ``namespace``, ``key_file``, and ``cameras`` (true: publish every
    FLS's detections, for FLSs that run one to a process).
    """
    spec = WorldSpec(**vars(description_from(values)))
    replica = WorldReplica(spec.build())
    namespace, key = str(values["namespace"]), program_key(context, values, world=True)
    nodes: list[Node] = [
        WorldNode(replica, namespace=namespace, context=context, key=key, parameter_services=True)
    ]
    declare_startup(nodes[0], values)
    if values["cameras"]:
        nodes.append(
            SimulatedCameras(
                replica, replica.ids.tolist(), namespace=namespace, context=context, key=key
            )
        )
    return nodes


def main(args: list[str] | None = None) -> int:
    """``ros2 run swazure_ros world --cloud torus:120 --beta 0.5``."""
    return run_process(build_world, args, usage=USAGE, startup=STARTUP)
