"""Swazure from Python: the engine as library functions, and a client of a running swarm.

The engine (no ROS; :mod:`.engine`)::

    from swazure_ros import api
    setup = api.build_swarm("torus:120", scale=5, beta=0.5)
    result = api.evaluate(setup)            # result.summary, result.pairs (pyarrow.Table)

A running swarm (rclpy over DDS; :mod:`.client`)::

    with api.connect(namespace="swarm", domain_id=201) as swarm:
        swarm.neighbours(0)
        swarm.compute_pose(0, 5)

Importing this module loads no rclpy: the client loads it when it connects.
"""

from ..core.errors import CloudError, OptionError, RunError, SensorError, SwazureError
from ..core.pipeline import RunOptions
from ..sim.world import WorldSpec
from .client import SwarmClient, compute_all, connect, spawn
from .engine import (
    Result,
    SwarmSetup,
    build_swarm,
    cloud_of,
    evaluate,
    move_obstructing,
    move_source,
)

__all__ = [
    "CloudError",
    "OptionError",
    "Result",
    "RunError",
    "RunOptions",
    "SensorError",
    "SwarmClient",
    "SwarmSetup",
    "SwazureError",
    "WorldSpec",
    "build_swarm",
    "cloud_of",
    "compute_all",
    "connect",
    "evaluate",
    "move_obstructing",
    "move_source",
    "spawn",
]
