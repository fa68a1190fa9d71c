"""A scene as RViz markers (visualization_msgs/MarkerArray)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from ...core.arrays import FloatArray
from ...core.frames import METRES_PER_CM

if TYPE_CHECKING:
    from ...view.scene import Scene


def _colour(rgba: Sequence[float]) -> ColorRGBA:
    red, green, blue, alpha = (float(value) for value in rgba)
    return ColorRGBA(r=red, g=green, b=blue, a=alpha)


def _point(xyz: Sequence[float] | FloatArray) -> Point:
    x, y, z = (float(value) * METRES_PER_CM for value in xyz)
    return Point(x=x, y=y, z=z)


def scene_markers(scene: Scene, stamp: Time) -> MarkerArray:
    """The scene as RViz markers (metres): FLSs as one sphere list, paths, moves as arrows.

    The first marker deletes what an earlier scene drew.
    """
    # Here, not at import: the scene is the viewer's, which an FLS alone never runs.
    from ...view.scene import MOVE_COLOUR, SCENE_FRAME

    header = Header(stamp=stamp, frame_id=SCENE_FRAME)
    markers = [Marker(header=header, action=Marker.DELETEALL)]
    diameter = 2 * scene.radius * METRES_PER_CM
    flss = Marker(header=header, ns="flss", id=0, type=Marker.SPHERE_LIST, action=Marker.ADD)
    flss.pose.orientation.w = 1.0
    flss.scale = Vector3(x=diameter, y=diameter, z=diameter)
    flss.points = [_point(point) for point in scene.points]
    flss.colors = [_colour(colour) for colour in scene.colours]
    markers.append(flss)
    for index, path in enumerate(scene.paths):
        line = Marker(header=header, ns="paths", id=index, type=Marker.LINE_STRIP)
        line.pose.orientation.w = 1.0
        line.scale.x = diameter / 4
        line.color = _colour(path.colour)
        line.points = [_point(point) for point in path.points]
        line.text = path.label
        markers.append(line)
    for index, (start, end) in enumerate(scene.moves):
        arrow = Marker(header=header, ns="moves", id=index, type=Marker.ARROW)
        arrow.pose.orientation.w = 1.0
        arrow.scale = Vector3(x=diameter / 6, y=diameter / 3, z=diameter / 3)
        arrow.color = _colour(MOVE_COLOUR)
        arrow.points = [_point(start), _point(end)]
        markers.append(arrow)
    return MarkerArray(markers=markers)
