"""ROS fixtures: one Context per test on the test's own domain id (test/conftest.py)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

rclpy = pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy wheels) is not installed")


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
