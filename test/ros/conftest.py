"""ROS fixtures: one Context per test on a reserved domain id, localhost discovery only."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from ..conftest import stop_ros2_daemons

rclpy = pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy wheels) is not installed")


@pytest.fixture
def domain() -> Iterator[int]:
    """A ROS domain id no other test on this machine holds, also set in the environment."""
    from domain_coordinator import domain_id

    # Keep test traffic on this machine, away from any other DDS participant.
    saved = {
        key: os.environ.get(key) for key in ("ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_DOMAIN_ID")
    }
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    with domain_id() as reserved:
        os.environ["ROS_DOMAIN_ID"] = str(reserved)
        try:
            yield reserved
        finally:
            stop_ros2_daemons(reserved)
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


def make_context(domain: int, args: list[str] | None = None) -> object:
    """An initialised rclpy Context on ``domain`` with global ROS arguments ``args``."""
    ctx = rclpy.context.Context()
    rclpy.init(args=args or [], context=ctx, domain_id=domain)
    return ctx


@pytest.fixture
def context(domain: int) -> Iterator[object]:
    """A fresh rclpy Context on the test's own domain."""
    ctx = make_context(domain)
    try:
        yield ctx
    finally:
        ctx.try_shutdown()
