"""The ArUco detector node over real DDS: the intrinsics it takes, and what it publishes."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image
from swazure_interfaces.msg import Detections

from swazure_ros.camera.aruco import MarkerPose, full_image, render
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera
from swazure_ros.ros.convert.sensing import camera_info_message, image_message
from swazure_ros.ros.nodes.detector_node import ArucoDetectorNode
from swazure_ros.ros.plumbing.names import DETECTIONS_QOS
from swazure_ros.ros.plumbing.node import SwarmNode

from ...waits import PATIENCE, wait_until

FRAME = "fls_0_camera_optical"


@pytest.mark.parametrize(
    "intrinsics",
    [{"fx": 1e-300, "fy": 1e-300}, {"cx": 1e300, "cy": 1e300}, {"fx": math.nan}],
    ids=["fx=fy=1e-300", "cx=cy=1e300", "fx=nan"],
)
def test_intrinsics_that_give_no_finite_pose_are_dropped_and_nothing_non_finite_is_published(
    context, intrinsics
):
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    detector = ArucoDetectorNode(context=context)
    driver = SwarmNode("camera_driver", context=context)
    images = driver.create_publisher(Image, "image_raw", qos_profile_sensor_data)
    infos = driver.create_publisher(CameraInfo, "camera_info", qos_profile_sensor_data)
    received: list[Detections] = []
    driver.create_subscription(Detections, "detections", received.append, DETECTIONS_QOS)
    executor = SingleThreadedExecutor(context=context)
    for node in (detector, driver):
        executor.add_node(node)
    pixels = full_image(camera, render(camera, MarkerPose(65.0), np.random.default_rng(0)))

    def feed(intrinsics_of) -> None:
        stamp = driver.get_clock().now().to_msg()
        infos.publish(camera_info_message(intrinsics_of, stamp, FRAME))
        images.publish(image_message(pixels, stamp, FRAME))
        executor.spin_once(timeout_sec=0.2)

    def dropped_infos() -> int:
        return sum(n for (topic, _), n in detector.guard.dropped.items() if topic == "camera_info")

    try:
        # Issue 66: a camera_info of fx = fy = 1e-300 made the detector publish NaN.
        bad = replace(camera, **intrinsics)
        assert wait_until(lambda: dropped_infos() >= 5, PATIENCE, lambda: feed(bad)), "not dropped"
        assert detector.images_read == 0  # no intrinsics taken: no image read
        # The node keeps running: good intrinsics are taken, and bad ones after them are
        # dropped while the good ones stay.
        assert wait_until(lambda: len(received) >= 3, PATIENCE, lambda: feed(camera)), (
            "no detections"
        )
        before = dropped_infos()
        taken = len(received)
        assert wait_until(
            lambda: dropped_infos() >= before + 5 and len(received) >= taken + 3,
            PATIENCE,
            lambda: feed(bad),
        ), "bad intrinsics after good ones"
    finally:
        executor.shutdown()
        driver.destroy_node()
        detector.destroy_node()
    positions = [
        (d.pose.pose.position.x, d.pose.pose.position.y, d.pose.pose.position.z)
        for message in received
        for d in message.detections
    ]
    assert positions and np.all(np.isfinite(positions)), positions
    # Every centre is the good intrinsics' (the same frame each time): 65 mm ahead.
    assert np.allclose(np.asarray(positions)[:, 2], 0.065, rtol=0.05), positions
