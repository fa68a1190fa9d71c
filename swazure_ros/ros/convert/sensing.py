"""What an FLS senses, as messages: measurements, detections, camera images, world revisions
and the FLSs' frames (tf2)."""

from __future__ import annotations

import array
from typing import TYPE_CHECKING

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseWithCovariance, TransformStamped
from numpy.typing import NDArray
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Header
from swazure_interfaces.msg import (
    Detections,
    MarkerDetection,
    WorldState,
)
from tf2_msgs.msg import TFMessage

from ...core.arrays import FloatArray, IntArray
from ...core.frames import SWARM_FRAME, fls_frame, to_centimetres, to_metres
from ...core.observe import Measurement, NeighbourSets
from ...core.sensor import Sensor
from ..plumbing.cdr import ENCAPSULATION, aligned, serialize
from ..plumbing.names import WORLD_REACH
from ..security.guard import check, check_finite, check_ids, check_size

if TYPE_CHECKING:
    from ...camera.aruco import Camera


#: Readings a Detections message may hold: a camera reads a few dozen markers at most.
MAX_DETECTIONS = 4096


def detections_message(
    fls_id: int,
    measurement: Measurement,
    markers: IntArray,
    sensor: Sensor,
    stamp: Time,
    revision: int = 0,
) -> Detections:
    """What FLS ``fls_id``'s simulated camera reads in world ``revision``, as a camera would.

    ``markers`` (K,) are the markers of the measured FLSs; each pose is centre
    to centre in metres in the FLS's frame, its position variance the
    sensor's length error at that distance, squared, on each axis; its
    rotation unknown (variance -1).
    """
    message = Detections(revision=revision)
    message.header.stamp = stamp
    message.header.frame_id = fls_frame(fls_id)
    error = np.abs(sensor.relative_error(measurement.tracking) * measurement.tracking)
    for marker, vector, sigma in zip(
        markers.tolist(),
        to_metres(measurement.vector).tolist(),
        to_metres(error).tolist(),
        strict=True,
    ):
        pose = PoseWithCovariance()
        pose.pose.position = Point(x=vector[0], y=vector[1], z=vector[2])
        pose.pose.orientation.w = 1.0
        covariance = np.zeros((6, 6))
        covariance[[0, 1, 2], [0, 1, 2]] = sigma * sigma
        covariance[[3, 4, 5], [3, 4, 5]] = -1.0
        pose.covariance = covariance.ravel().tolist()
        message.detections.append(MarkerDetection(marker_id=marker, pose=pose))
    return message


def detections_from_message(message: Detections, fls_id: int) -> tuple[IntArray, FloatArray]:
    """Markers (K,) and centre-to-centre vectors (K, 3), cm, of FLS ``fls_id``'s detections.

    MessageError unless the poses are in the FLS's own frame (a detector's
    optical-frame poses must be moved there by the camera's mount first),
    finite, within 10 km and at most MAX_DETECTIONS.
    """
    check(
        message.header.frame_id == fls_frame(fls_id),
        f"detections in frame {message.header.frame_id[:40]!r}, not {fls_frame(fls_id)}",
    )
    check_size(message.detections, MAX_DETECTIONS, "detections")
    markers = np.array([one.marker_id for one in message.detections], dtype=np.int64)
    positions = [one.pose.pose.position for one in message.detections]
    vectors = np.array([[p.x, p.y, p.z] for p in positions], dtype=np.float64).reshape(-1, 3)
    check_finite(vectors, "detection positions")
    # A camera reads metres at most; far-off ones overflow once in centimetres.
    check(bool(np.all(np.abs(vectors) <= WORLD_REACH / 100.0)), "a detection beyond 10 km")
    return markers, to_centimetres(vectors)


def neighbour_fields(sets: NeighbourSets) -> dict[str, list[int]]:
    """GetNeighbours response fields from neighbour sets of FLS ids."""
    return {
        "blind_ids": sets.blind.tolist(),
        "sweet_ids": sets.sweet.tolist(),
        "visible_sweet_ids": sets.visible_sweet.tolist(),
        "decaying_ids": sets.visible_decaying.tolist(),
    }


def world_message(
    revision: int, ids: NDArray[np.int64], points: FloatArray, stamp: Time
) -> WorldState:
    """Every FLS's position as a WorldState message."""
    message = WorldState(revision=revision)
    message.fls_ids = array.array("I", np.asarray(ids, dtype=np.uint32).tobytes())
    message.positions = array.array("d", np.asarray(points, dtype=np.float64).tobytes())
    message.header.stamp = stamp
    message.header.frame_id = SWARM_FRAME  # positions in cm, as the protocol's (docs/frames.md)
    return message


class FlsFrames:
    """The /tf_static message of every FLS's frame, its CDR bytes kept and set anew.

    A heuristic makes ten world revisions a second, and each sends every FLS's
    frame (a /tf_static message holds them all): making a TransformStamped per
    FLS took more than the revision's other work, and rclpy's conversion of
    a thousand of them 14 ms more. The bytes are laid out once (the frame
    names fix where every field lies); a revision writes its stamp and the
    FLSs' places into them, the bytes ``cdr.serialize`` gives the message.
    """

    def __init__(self, ids: NDArray[np.int64]) -> None:
        message = TFMessage()
        for fls_id in np.asarray(ids).tolist():
            frame = TransformStamped(child_frame_id=fls_frame(fls_id))
            frame.header.frame_id = SWARM_FRAME
            frame.transform.rotation.w = 1.0  # an FLS's axes are the swarm's
            message.transforms.append(frame)
        self._bytes = bytearray(serialize(message))
        check(self._bytes[1] == 1, "CDR of this machine is not little-endian")
        # Where each frame's stamp and translation lie, counted from after the 4-byte
        # encapsulation header as CDR aligns them: a sequence's length, then per frame
        # the stamp (int32, uint32), two strings (a uint32 length, the characters and a
        # NUL), the translation (aligned to 8) and the rotation (7 float64s in all).
        stamps, places, at = [], [], 4
        for frame in message.transforms:
            at = aligned(at, 4)
            stamps.append(at // 4)
            at += 8
            for name in (frame.header.frame_id, frame.child_frame_id):
                at = aligned(at, 4) + 4 + len(name.encode()) + 1
            at = aligned(at, 8)
            places.append(at // 8)
            at += 7 * 8
        self._stamps = np.array(stamps, dtype=np.int64)
        self._places = np.array(places, dtype=np.int64)
        body = memoryview(self._bytes)[ENCAPSULATION:]
        self._words = np.frombuffer(body[: len(body) // 4 * 4], dtype="<i4")
        self._doubles = np.frombuffer(body[: len(body) // 8 * 8], dtype="<f8")

    def serialized(self, points: FloatArray, stamp: Time) -> bytes:
        """The message's CDR bytes with the FLSs at ``points`` (N, 3), cm, stamped ``stamp``."""
        metres = to_metres(np.asarray(points, dtype=np.float64))
        for axis in range(3):
            self._doubles[self._places + axis] = metres[:, axis]
        self._words[self._stamps] = stamp.sec
        self._words[self._stamps + 1] = np.uint32(stamp.nanosec).view(np.int32)
        return bytes(self._bytes)


def world_positions(
    message: WorldState, swarm: IntArray, reach: float
) -> tuple[NDArray[np.int64], FloatArray]:
    """FLS ids (N,) and their positions (N, 3), cm, from a WorldState message.

    MessageError unless every id is one of ``swarm``'s (sorted ids), once, and
    every position is finite and within ``reach`` cm of the origin.
    """
    check_size(message.fls_ids, len(swarm), "fls_ids")
    check(len(message.positions) == 3 * len(message.fls_ids), "not 3 positions per FLS")
    ids = check_ids(np.frombuffer(message.fls_ids, dtype=np.uint32), swarm, "fls_ids")
    check(len(np.unique(ids)) == len(ids), "an FLS is listed twice")
    points = check_finite(np.frombuffer(message.positions, dtype=np.float64), "positions")
    check(bool(np.all(np.abs(points) <= reach)), f"a position beyond {reach:g} cm")
    return ids, points.reshape(-1, 3).copy()


def image_message(image: NDArray[np.uint8], stamp: Time, frame_id: str) -> Image:
    """A grey (H, W) image as sensor_msgs/Image, mono8."""
    rows, columns = image.shape
    return Image(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=rows,
        width=columns,
        encoding="mono8",
        is_bigendian=0,
        step=columns,
        data=np.ascontiguousarray(image).tobytes(),
    )


def camera_info_message(camera: Camera, stamp: Time, frame_id: str) -> CameraInfo:
    """The camera's intrinsics as sensor_msgs/CameraInfo (no distortion: the renderer has none)."""
    matrix = camera.matrix
    projection = np.hstack([matrix, np.zeros((3, 1))])
    return CameraInfo(
        header=Header(stamp=stamp, frame_id=frame_id),
        height=camera.height,
        width=camera.width,
        distortion_model="plumb_bob",
        d=[0.0] * 5,
        k=matrix.ravel().tolist(),
        r=np.eye(3).ravel().tolist(),
        p=projection.ravel().tolist(),
    )
