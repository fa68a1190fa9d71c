"""The ``coordinator`` program: the coordinator of a swarm whose FLSs run one to a process.

``ros2 run swazure_ros coordinator --cloud torus:120 --scale 5 --beta 0.5``
"""

from __future__ import annotations

from rclpy.context import Context
from rclpy.node import Node

from ..nodes import coordinator
from ..nodes.coordinator import Coordinator
from ..nodes.instance import program_key
from ..plumbing.parameters import ParameterSpec, at_least
from ..plumbing.process import run_process
from ..plumbing.startup import (
    DESCRIPTION_PARAMETERS,
    KEY_FILE,
    NAMESPACE,
    SWARM_INSTANCE,
    StartupValues,
    declare_startup,
    description_from,
    program_help,
)

HOSTS = ParameterSpec(
    "hosts",
    0,
    "the radios that acknowledge each round; 0: one per FLS, each FLS in its own process",
    at_least(0),
)
#: What the program takes as arguments, before it builds its node.
STARTUP = (NAMESPACE, KEY_FILE, SWARM_INSTANCE, HOSTS, *DESCRIPTION_PARAMETERS)
USAGE = program_help(
    "coordinator",
    """The swarm's coordinator, for FLSs that run one to a process: it keeps the round
clock of the swarm's discovery runs, answers ~/compute_pose and plans the
heuristics' moves on the swarm's shape. Give it the swarm's description, as every
FLS has it.

  ros2 run swazure_ros coordinator --cloud torus:120 --scale 5 --beta 0.5""",
    STARTUP,
    coordinator.PARAMETERS,
)


def build_coordinator(context: Context, values: StartupValues) -> list[Node]:
    """The coordinator's process, for a swarm whose FLSs run one to a process.

    ``values`` (STARTUP): the swarm's description (``cloud``, ``beta`` or ``radius``,
    ...), ``namespace``, ``key_file``, and ``hosts``: the radios that
    acknowledge each round (0: one per FLS, each FLS in its own process).
    It plans heuristics' moves on the description's shape, as the packed one does.
    """
    description = description_from(values)
    # The shape and the sensor: the pairs are each FLS's process's own.
    shape = description.assigned()
    ids = shape.cloud_index
    hosts = int(values["hosts"]) or len(ids)
    node = Coordinator(
        ids.tolist(),
        hosts,
        shape=shape,
        sensor=description.sensor(),
        namespace=str(values["namespace"]),
        context=context,
        key=program_key(context, values),
        parameter_services=True,
    )
    declare_startup(node, values)
    return [node]


def main(args: list[str] | None = None) -> int:
    """``ros2 run swazure_ros coordinator --cloud torus:120 --beta 0.5``."""
    return run_process(build_coordinator, args, usage=USAGE, startup=STARTUP)
