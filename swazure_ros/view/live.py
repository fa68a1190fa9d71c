"""The scene served live to Foxglove over its WebSocket protocol (foxglove-sdk).

Foxglove's 3D panel draws ``foxglove.SceneUpdate`` messages; the SDK serves
them as protobuf on a channel of our choosing. A viewer that connects later
gets the current scene at once: the server sends it again on every new
subscription (a WebSocket channel keeps no last message, unlike a latched
ROS topic).
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.errors import SwazureError
from ..core.frames import METRES_PER_CM
from .scene import MOVE_COLOUR, SCENE_FRAME, Scene


def _quaternion_from_x(direction: NDArray[np.float64]) -> tuple[float, float, float, float]:
    """(x, y, z, w) of the rotation taking +x to ``direction`` (3,), which need not be unit."""
    unit = direction / np.linalg.norm(direction)
    x_axis = np.array([1.0, 0.0, 0.0])
    axis = np.cross(x_axis, unit)
    w = 1.0 + float(unit @ x_axis)
    if w < 1e-9:  # opposite to +x: half a turn about z
        return (0.0, 0.0, 1.0, 0.0)
    quaternion = np.array([*axis, w]) / np.linalg.norm([*axis, w])
    return (float(quaternion[0]), float(quaternion[1]), float(quaternion[2]), float(quaternion[3]))


def scene_update(scene: Scene) -> Any:
    """The scene as a ``foxglove.SceneUpdate`` in metres: entities flss, paths, moves."""
    from foxglove import messages as fox

    def colour(rgba: Any) -> Any:
        red, green, blue, alpha = (float(value) for value in rgba)
        return fox.Color(r=red, g=green, b=blue, a=alpha)

    def point(xyz: Any) -> Any:
        x, y, z = (float(value) * METRES_PER_CM for value in xyz)
        return fox.Point3(x=x, y=y, z=z)

    def pose(xyz: Any, orientation: tuple[float, float, float, float] = (0, 0, 0, 1)) -> Any:
        x, y, z = (float(value) * METRES_PER_CM for value in xyz)
        qx, qy, qz, qw = orientation
        return fox.Pose(
            position=fox.Vector3(x=x, y=y, z=z),
            orientation=fox.Quaternion(x=qx, y=qy, z=qz, w=qw),
        )

    diameter = 2 * scene.radius * METRES_PER_CM
    size = fox.Vector3(x=diameter, y=diameter, z=diameter)
    spheres = [
        fox.SpherePrimitive(pose=pose(xyz), size=size, color=colour(rgba))
        for xyz, rgba in zip(scene.points, scene.colours, strict=True)
    ]
    lines = [
        fox.LinePrimitive(
            type=fox.LinePrimitiveLineType.LineStrip,
            pose=pose((0, 0, 0)),
            thickness=diameter / 4,
            points=[point(xyz) for xyz in path.points],
            color=colour(path.colour),
        )
        for path in scene.paths
    ]
    arrows = []
    for start, end in scene.moves:
        length = float(np.linalg.norm(end - start)) * METRES_PER_CM
        if length == 0:
            continue
        arrows.append(
            fox.ArrowPrimitive(
                pose=pose(start, _quaternion_from_x(end - start)),
                shaft_length=length * 0.7,
                shaft_diameter=diameter / 6,
                head_length=length * 0.3,
                head_diameter=diameter / 3,
                color=colour(MOVE_COLOUR),
            )
        )
    entities = [
        fox.SceneEntity(frame_id=SCENE_FRAME, id="flss", spheres=spheres),
        fox.SceneEntity(frame_id=SCENE_FRAME, id="paths", lines=lines),
        fox.SceneEntity(frame_id=SCENE_FRAME, id="moves", arrows=arrows),
    ]
    return fox.SceneUpdate(entities=entities)


class LiveView:
    """A Foxglove WebSocket server showing one scene on ``topic``; show() replaces it."""

    def __init__(self, topic: str, port: int = 8765, host: str = "127.0.0.1") -> None:
        import foxglove
        from foxglove.channels import SceneUpdateChannel
        from foxglove.websocket import ServerListener

        self._lock = threading.Lock()
        self._update: Any = None
        view = self

        class Listener(ServerListener):
            # The SDK calls this on its own thread when a viewer subscribes.
            def on_subscribe(self, client: Any, channel: Any) -> None:
                view._resend()

        try:
            self.server = foxglove.start_server(
                name="swazure", host=host, port=port, server_listener=Listener()
            )
        except Exception as err:  # the SDK reports a port in use as a bare RuntimeError
            raise SwazureError(f"cannot serve the view on {host}:{port} ({err})") from err
        self.channel = SceneUpdateChannel(topic)

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        return int(self.server.port)

    def show(self, scene: Scene) -> None:
        """Send ``scene`` to every viewer, and to those who come later."""
        update = scene_update(scene)
        with self._lock:
            self._update = update
        self.channel.log(update)

    def _resend(self) -> None:
        with self._lock:
            update = self._update
        if update is not None:
            self.channel.log(update)

    def close(self) -> None:
        """Stop serving."""
        self.channel.close()
        self.server.stop()
