"""An ArUco detector on a camera's image stream: `ros2 run swazure_ros aruco_detector`.

It subscribes to ``image_raw`` (sensor_msgs/Image: mono8, or bgr8/rgb8
turned grey) and ``camera_info`` (sensor_msgs/CameraInfo), reads every marker
of the camera file's dictionary in each image, refines and solves each with
the rendering camera's own code (:class:`~swazure_ros.camera.aruco.Detector`:
cornerSubPix, IPPE_SQUARE and its choice between the two poses), and
publishes the marker centres on ``detections`` (swazure_interfaces/
Detections) in the image's frame, the camera's optical frame, in metres.
Remap the three names onto a camera driver's topics, e.g.
``-r image_raw:=/camera/image_raw``.

The intrinsics are the camera_info's K; an image that comes before any
camera_info is dropped. The camera file (``camera_file``) gives the
dictionary, the marker's side and the corner window.

With the swarm's key (``key_file``), the detections are signed like the
swarm's messages: an FLS takes no detection that no process of its swarm
made (docs/security.md). The camera driver's images stay unsigned: run the
detector on the FLS's own host, beside its driver.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from geometry_msgs.msg import PoseWithCovariance
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image
from swazure_interfaces.msg import Detections, MarkerDetection

from ...camera.aruco import Camera, Detector
from ...camera.camera_file import MAX_IMAGE_PX, intrinsics_problem
from ...core.errors import SwazureError
from ...files.reading import config_dir
from ...files.sensors import load_camera
from ..plumbing.names import DETECTIONS_QOS
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterError, ParameterSpec
from ..plumbing.process import run_process
from ..plumbing.startup import KEY_FILE, NAMESPACE, SWARM_INSTANCE, StartupValues, program_help
from ..security.auth import SwarmKey
from ..security.guard import Guard, check
from .instance import program_key

#: The camera the published model's sensor was measured with.
DEFAULT_CAMERA = "cameras/rpi-camera-module-3-wide.yaml"
#: Millimetres in a metre: the solver works in the camera file's millimetres.
MM_PER_METRE = 1000.0
#: Channels of the colour encodings taken, by encoding.
_COLOUR = {"bgr8": 2, "rgb8": 0}


def grey_image(message: Image) -> np.ndarray:
    """(height, width) uint8 grey pixels of an Image; MessageError for other encodings."""
    check(
        message.encoding in ("mono8", *_COLOUR),
        f"encoding {message.encoding[:20]!r}: mono8, bgr8 or rgb8",
    )
    channels = 1 if message.encoding == "mono8" else 3
    check(
        message.step >= message.width * channels
        and len(message.data) >= message.step * message.height,
        "image data shorter than its height, width and step say",
    )
    rows = np.frombuffer(bytes(message.data), np.uint8)[: message.step * message.height]
    pixels = rows.reshape(message.height, message.step)[:, : message.width * channels]
    if channels == 1:
        return pixels
    import cv2

    code = cv2.COLOR_BGR2GRAY if message.encoding == "bgr8" else cv2.COLOR_RGB2GRAY
    return np.asarray(cv2.cvtColor(pixels.reshape(message.height, message.width, 3), code))


def camera_file() -> ParameterSpec:
    """The detector's camera file parameter, defaulting to the installed wide lens's."""
    return ParameterSpec(
        "camera_file",
        str(config_dir() / DEFAULT_CAMERA),
        "camera file (docs/camera.md): the markers' dictionary and side (mm), the corner window",
    )


class ArucoDetectorNode(SwarmNode):
    """Reads ArUco markers in a camera's images and publishes where they are."""

    def __init__(
        self, *, context: Context | None = None, namespace: str = "", key: SwarmKey | None = None
    ) -> None:
        super().__init__(
            "aruco_detector", namespace=namespace, context=context, parameter_services=True
        )
        path = self.declare(camera_file())
        try:
            self.camera: Camera = load_camera(path)
        except SwazureError as err:
            raise ParameterError(f"{self.get_fully_qualified_name()}: camera_file: {err}") from err
        self._detector: Detector | None = None
        self._intrinsics: tuple[float, float, float, float] | None = None
        self.guard = Guard(self, key)
        self._detections = self.create_publisher(Detections, "detections", DETECTIONS_QOS)
        self.guard.subscribe(CameraInfo, "camera_info", self._on_info, qos_profile_sensor_data)
        self.guard.subscribe(Image, "image_raw", self._on_image, qos_profile_sensor_data)
        self.images_read = 0

    def _on_info(self, info: CameraInfo) -> None:
        fx, _, cx, _, fy, cy = (float(value) for value in info.k[:6])
        # Dropped, and the last good intrinsics kept: a solve with them could give NaN.
        problem = intrinsics_problem(fx, fy, cx, cy)
        check(problem is None, f"K: {problem}")
        check(
            max(info.width, info.height) <= MAX_IMAGE_PX,
            f"an image of more than {MAX_IMAGE_PX} px a side",
        )
        if self._intrinsics != (fx, fy, cx, cy):
            self._intrinsics = (fx, fy, cx, cy)
            camera = replace(self.camera, fx=fx, fy=fy, cx=cx, cy=cy)
            camera = replace(camera, width=int(info.width), height=int(info.height))
            self._detector = Detector(camera)

    def _on_image(self, image: Image) -> None:
        if self._detector is None:
            return  # no intrinsics yet
        pixels = grey_image(image)
        message = Detections()
        message.header = image.header  # the camera's optical frame, the frame's time
        for marker, corners in self._detector.markers(pixels):
            centre = self._detector.solve(corners)
            if centre is None:
                continue
            pose = PoseWithCovariance()
            x, y, z = (float(value) for value in centre / MM_PER_METRE)
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = x, y, z
            pose.pose.orientation.w = 1.0
            covariance = np.zeros((6, 6))
            covariance[[3, 4, 5], [3, 4, 5]] = -1.0  # the rotation is not reported
            pose.covariance = covariance.ravel().tolist()
            message.detections.append(MarkerDetection(marker_id=marker, pose=pose))
        self.images_read += 1
        self._detections.publish(self.guard.key.serialize(message))


def build_detector(context: Context, values: StartupValues) -> list[Node]:
    """The detector's process: one node; ``values``: STARTUP's."""
    return [ArucoDetectorNode(context=context, key=program_key(context, values))]


#: What the program takes as arguments: the swarm's key, to sign with.
STARTUP = (NAMESPACE, KEY_FILE, SWARM_INSTANCE)


def main(args: list[str] | None = None) -> int:
    """``ros2 run swazure_ros aruco_detector --ros-args -r image_raw:=/camera/image_raw``."""
    usage = program_help(
        "aruco_detector",
        """ArUco detections from any camera driver: it reads image_raw and camera_info
(sensor data QoS) and publishes detections (swazure_interfaces/Detections: each
marker's centre in the camera's optical frame, m), as an FLS's camera feeds the FLS.

  ros2 run swazure_ros aruco_detector --ros-args -r image_raw:=/camera/image_raw \\
      -r camera_info:=/camera/camera_info -r detections:=/swarm/fls_7/camera/detections""",
        STARTUP,
        [camera_file()],
    )
    return run_process(build_detector, args, usage=usage, startup=STARTUP)
