"""The app runs swarms over ROS: the ROS fixtures (a domain of each test's own)."""

from ..ros.conftest import context  # noqa: F401  (a fixture)
