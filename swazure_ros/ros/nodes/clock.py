"""The simulated clock: a node that publishes ``/clock`` for nodes with ``use_sim_time``.

Whoever drives a simulation (a track run, a test) sets the time step by step,
so that a run is as fast as the machine allows and its stamps are the same
on every run.
"""

from __future__ import annotations

from rclpy.context import Context
from rclpy.time import Time
from rosgraph_msgs.msg import Clock

from ..plumbing.names import CLOCK_QOS, CLOCK_TOPIC
from ..plumbing.node import SwarmNode


class SimClock(SwarmNode):
    """Publishes the simulated time on ``/clock``."""

    def __init__(self, *, context: Context | None = None, name: str = "sim_clock") -> None:
        super().__init__(name, context=context)
        self._publisher = self.create_publisher(Clock, CLOCK_TOPIC, CLOCK_QOS)
        self.nanoseconds = 0

    def set(self, nanoseconds: int) -> None:
        """Publish the simulated time ``nanoseconds``; it never runs backwards."""
        self.nanoseconds = max(self.nanoseconds, int(nanoseconds))
        self._publisher.publish(Clock(clock=Time(nanoseconds=self.nanoseconds).to_msg()))
