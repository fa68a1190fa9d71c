"""Swazure on ROS 2: relative pose of blind neighbours in a swarm of Flying Light Specks."""

__version__ = "0.2.0"
