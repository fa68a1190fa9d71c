"""The view node: the swarm's scene as RViz markers and, when asked, live in Foxglove.

It publishes the scene (``view.scene``) as a latched MarkerArray on
``/NAMESPACE/scene`` and, with a port, serves the same scene to Foxglove
over its WebSocket protocol (``view.live``). It follows the world's
revisions: a moved FLS is drawn where it is, with an arrow from its home.
"""

from __future__ import annotations

from rclpy.context import Context
from swazure_interfaces.msg import WorldState
from visualization_msgs.msg import MarkerArray

from ...view.live import LiveView
from ...view.scene import Scene, placed
from ..convert.markers import scene_markers
from ..convert.sensing import world_positions
from ..plumbing.names import SCENE_QOS, SCENE_TOPIC, WORLD_QOS, WORLD_REACH, WORLD_TOPIC
from ..plumbing.node import SwarmNode
from ..security.auth import SwarmKey
from ..security.guard import Guard

#: Seconds between redraws while the world moves: a viewer needs no more.
REDRAW_PERIOD = 0.2


class ViewNode(SwarmNode):
    """Shows a scene of the swarm; :meth:`show` replaces it."""

    def __init__(
        self,
        scene: Scene,
        *,
        namespace: str,
        context: Context,
        port: int | None = None,
        key: SwarmKey | None = None,
    ) -> None:
        super().__init__("view", namespace=namespace, context=context)
        self._home = scene.points.copy()
        self._scene = scene
        self._markers = self.create_publisher(MarkerArray, SCENE_TOPIC, SCENE_QOS)
        self.live = None if port is None else LiveView(f"/{namespace}/{SCENE_TOPIC}", port)
        self.guard = Guard(self, key)
        self.guard.subscribe(WorldState, WORLD_TOPIC, self._on_world, WORLD_QOS)
        self._stale = False
        self.create_timer(REDRAW_PERIOD, self._redraw)
        self.show(scene)

    @property
    def scene(self) -> Scene:
        """What is shown now."""
        return self._scene

    def show(self, scene: Scene) -> None:
        """Draw ``scene`` now, for RViz and Foxglove."""
        self._scene, self._stale = scene, False
        self._markers.publish(scene_markers(scene, self.get_clock().now().to_msg()))
        if self.live is not None:
            self.live.show(scene)

    def _on_world(self, message: WorldState) -> None:
        ids, points = world_positions(message, self._scene.ids, WORLD_REACH)
        self._scene = placed(self._scene, self._home, ids, points)
        self._stale = True

    def _redraw(self) -> None:
        if self._stale:
            self.show(self._scene)

    def destroy_node(self) -> None:
        """Stop serving Foxglove, then destroy the node."""
        if self.live is not None:
            self.live.close()
            self.live = None
        super().destroy_node()  # type: ignore[no-untyped-call]
