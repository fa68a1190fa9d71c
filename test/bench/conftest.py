"""The bench's smoke tests: the ROS fixtures of test/ros (a domain of each test's own)."""

from ..ros.conftest import domain  # noqa: F401  (a fixture, found by its name)
