"""The simulated clock: a node that publishes ``/clock`` for nodes with ``use_sim_time``.

Whoever drives a simulation (a track run, a test) sets the time step by step,
so that a run is as fast as the machine allows and its stamps are the same
on every run.
"""

from __future__ import annotations

from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

CLOCK_TOPIC = "/clock"
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


class SimClock(Node):
    """Publishes the simulated time on ``/clock``."""

    def __init__(self, *, context: Context | None = None, name: str = "sim_clock") -> None:
        super().__init__(
            name, context=context, enable_rosout=False, start_parameter_services=False
        )
        self._publisher = self.create_publisher(Clock, CLOCK_TOPIC, CLOCK_QOS)
        self.nanoseconds = 0

    def set(self, nanoseconds: int) -> None:
        """Publish the simulated time ``nanoseconds``; it never runs backwards."""
        self.nanoseconds = max(self.nanoseconds, int(nanoseconds))
        self._publisher.publish(Clock(clock=Time(nanoseconds=self.nanoseconds).to_msg()))
