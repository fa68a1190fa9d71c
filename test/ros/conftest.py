"""ROS fixtures: one Context per test on a reserved domain id, localhost discovery only."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

rclpy = pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy wheels) is not installed")


@pytest.fixture
def context() -> Iterator[object]:
    """A fresh rclpy Context on a domain id no other test on this machine holds."""
    from domain_coordinator import domain_id

    # Keep test traffic on this machine, away from any other DDS participant.
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    with domain_id() as reserved:
        ctx = rclpy.context.Context()
        rclpy.init(context=ctx, domain_id=reserved)
        try:
            yield ctx
        finally:
            ctx.try_shutdown()
