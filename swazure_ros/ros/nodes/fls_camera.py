"""An FLS node's camera, one part for each way it has one.

A simulated FLS (many to a process) can show what its rendering camera sees
aimed at a neighbour (:class:`CameraView`, the ``camera_view`` parameter); an
FLS in its own process senses by its camera's detections and follows the
heuristics' move commands (:class:`DetectedSensing`). Each part makes its
own endpoints on the FLS's node and hands what it learns to the node.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from sensor_msgs.msg import CameraInfo, Image
from swazure_interfaces.msg import Detections, MoveCommands

from ...core.frames import camera_optical_frame
from ...protocol.moves import commanded_points
from ...protocol.senses import DetectedSenses
from ..convert.discovery import moves_from_message
from ..convert.sensing import camera_info_message, detections_from_message, image_message
from ..convert.units import stamp_nanoseconds
from ..plumbing.names import (
    CAMERA_IMAGE_TOPIC,
    CAMERA_INFO_TOPIC,
    DETECTIONS_QOS,
    DETECTIONS_TOPIC,
    MOVE_QOS,
    MOVE_TOPIC,
    WORLD_REACH,
)
from ..plumbing.node import SwarmNode
from ..security.auth import SwarmKey
from ..security.guard import Guard, check

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ...camera.aruco import Camera

#: What a simulated camera shows aimed at a neighbour: (neighbour id, frame number) ->
#: the camera and its whole image (height, width), uint8.
Eyes = Callable[[int, int], "tuple[Camera, NDArray[np.uint8]]"]


class CameraView:
    """Each frame, what FLS ``fls_id``'s camera sees aimed at neighbour ``neighbour``'s marker,
    on ``~/camera/image_raw`` and ``~/camera/camera_info`` (docs/camera.md)."""

    def __init__(
        self, node: SwarmNode, fls_id: int, eyes: Eyes, neighbour: int, period: float
    ) -> None:
        self._node = node
        self._render = eyes
        self.fls_id = fls_id
        self.neighbour = neighbour
        self.frames_shown = 0
        self._images = node.create_publisher(Image, f"~/{CAMERA_IMAGE_TOPIC}", 1)
        self._infos = node.create_publisher(CameraInfo, f"~/{CAMERA_INFO_TOPIC}", 1)
        self._frames = node.create_timer(period, self._on_frame)

    def set_period(self, seconds: float) -> None:
        """Take a new frame period at once."""
        self._frames.timer_period_ns = round(seconds * 1e9)

    def _on_frame(self) -> None:
        camera, image = self._render(self.neighbour, self.frames_shown)
        self.frames_shown += 1
        stamp = self._node.get_clock().now().to_msg()
        frame_id = camera_optical_frame(self.fls_id)
        self._images.publish(image_message(image, stamp, frame_id))
        self._infos.publish(camera_info_message(camera, stamp, frame_id))


class DetectedSensing:
    """An FLS that senses by its own camera's detections (``~/camera/detections``) and moves
    where the heuristics' commands send it; ``on_change`` is called when what it senses
    changes. Its guard is its process's one: its radio's too."""

    def __init__(
        self,
        node: SwarmNode,
        fls_id: int,
        senses: DetectedSenses,
        key: SwarmKey | None,
        on_change: Callable[[], None],
    ) -> None:
        self.fls_id = fls_id
        self.senses = senses
        self._on_change = on_change
        self.guard = Guard(node, key)
        self.guard.subscribe(
            Detections, f"~/{DETECTIONS_TOPIC}", self._on_detections, DETECTIONS_QOS
        )
        # Where the heuristics send FLSs: every FLS hears every command.
        self.guard.subscribe(MoveCommands, MOVE_TOPIC, self._on_moves, MOVE_QOS)
        self._moves_stamp = 0

    def _on_detections(self, message: Detections) -> None:
        markers, vectors = detections_from_message(message, self.fls_id)
        check(message.revision < 2**63, f"revision {message.revision} out of range")
        self.senses.detect(markers, vectors, int(message.revision))
        self._on_change()

    def _on_moves(self, message: MoveCommands) -> None:
        senses = self.senses
        ids, kinds, displacement = moves_from_message(message, senses.ids, WORLD_REACH)
        # As the world node takes them (WorldNode._on_moves): in order, a batch a revision.
        stamp = stamp_nanoseconds(message.header.stamp)
        check(stamp >= self._moves_stamp, "older than the last batch of moves (a replay?)")
        self._moves_stamp = stamp
        if len(ids):
            home = senses.home(ids)
            senses.move(ids, commanded_points(home, kinds, displacement))
            self._on_change()
