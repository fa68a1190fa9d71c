"""The ``coordinator`` program: the coordinator of a swarm whose FLSs run one to a process.

``ros2 run swazure_ros coordinator --ros-args -p cloud:=torus:120 -p beta:=0.5``
"""

from __future__ import annotations

from rclpy.context import Context
from rclpy.node import Node

from ..core.evaluate import neighbourhood
from .auth import SwarmKey
from .coordinator import Coordinator
from .keys import key_from
from .runtime import (
    DESCRIPTION_PARAMETERS,
    declare_startup,
    description_from,
    run_process,
    startup_parameters,
)


def build_coordinator(context: Context) -> list[Node]:
    """The coordinator's process, for a swarm whose FLSs run one to a process.

    Parameters: the swarm's description (``cloud``, ``beta`` or ``radius``,
    ...), ``namespace``, ``key_file``, and ``hosts``: the radios that
    acknowledge each round (0: one per FLS, each FLS in its own process).
    It plans heuristics' moves on the description's shape, as the packed one does.
    """
    values = startup_parameters(
        context,
        {"namespace": "swarm", "key_file": "", "hosts": 0, **DESCRIPTION_PARAMETERS},
    )
    description = description_from(values)
    shape = neighbourhood(description.assigned(), description.sensor())
    ids = shape.swarm.cloud_index
    hosts = int(values["hosts"]) or len(ids)
    coordinator = Coordinator(
        ids.tolist(),
        hosts,
        shape=shape,
        namespace=str(values["namespace"]),
        context=context,
        key=SwarmKey(key_from(str(values["key_file"]))),
        parameter_services=True,
    )
    declare_startup(coordinator, values)
    return [coordinator]


def main(args: list[str] | None = None) -> int:
    """``ros2 run swazure_ros coordinator --ros-args -p cloud:=torus:120 -p beta:=0.5``."""
    return run_process(build_coordinator, args)
