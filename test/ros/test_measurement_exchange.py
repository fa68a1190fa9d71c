"""Two rclpy nodes in one process exchange a RelativePose over real DDS."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from swazure_ros.core.hop_errors import measured_vectors
from swazure_ros.core.sensor import SWEET

from ..conftest import A, B, scene
from ..waits import PATIENCE, wait_until

msgs = pytest.importorskip("swazure_interfaces.msg", reason="msg_defs is not built")

RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


def test_measurement_message_arrives_with_its_content(context, sensor):
    swarm = scene(A, B)
    vector = measured_vectors(sensor, swarm.points, swarm.radius, [A], [B])[0]
    talker = Node("fls_0", context=context, enable_rosout=False)
    listener = Node("fls_1", context=context, enable_rosout=False)
    publisher = talker.create_publisher(msgs.RelativePose, "measurements", RELIABLE)
    received: list[object] = []
    listener.create_subscription(msgs.RelativePose, "measurements", received.append, RELIABLE)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(talker)
    executor.add_node(listener)
    try:
        message = msgs.RelativePose()
        message.header.stamp = talker.get_clock().now().to_msg()
        message.header.frame_id = "swarm"
        message.source_id, message.target_id = A, B
        message.range_class = msgs.RelativePose.RANGE_SWEET
        message.line_of_sight = True
        message.vector.x, message.vector.y, message.vector.z = map(float, vector)
        message.tracking_distance = float(np.linalg.norm(vector) - 2 * swarm.radius)

        def publish_and_spin():
            publisher.publish(message)  # again until the subscription has matched
            executor.spin_once(timeout_sec=0.1)

        assert wait_until(lambda: received, PATIENCE, publish_and_spin), "no message arrived"
        got = received[0]
        assert (got.source_id, got.target_id) == (A, B)
        assert got.range_class == msgs.RelativePose.RANGE_SWEET
        assert msgs.RelativePose.RANGE_SWEET == SWEET
        assert got.line_of_sight is True
        assert got.header.frame_id == "swarm"
        assert [got.vector.x, got.vector.y, got.vector.z] == vector.tolist()
        assert got.tracking_distance == message.tracking_distance
    finally:
        executor.shutdown()
        talker.destroy_node()
        listener.destroy_node()
