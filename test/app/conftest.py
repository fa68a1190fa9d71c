"""The app runs swarms over ROS: the ROS fixtures (a domain of the test's own)."""

from ..ros.conftest import context, domain  # noqa: F401  (fixtures)
