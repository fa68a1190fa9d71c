"""Ask a running swarm's coordinator for one source FLS's pose relative to a target."""

from __future__ import annotations

import time
from typing import Any

from rclpy.executors import SingleThreadedExecutor
from swazure_interfaces.srv import ComputePose

from ...core.errors import RunError, SwazureError
from ...protocol.discovery.estimate import Estimate
from ..convert.discovery import pose_estimate_from_message
from ..plumbing.names import COMPUTE_POSE_SERVICE, COORDINATOR, ESTIMATOR_CODES, policy_code
from ..plumbing.runtime import SwarmNode, init_context

#: Seconds after which a query that sees no node of the swarm at all gives up, whatever
#: its timeout: a swarm that is coming up shows its nodes long before its coordinator.
#: Not less: a loaded 2-core machine took over 3 s to discover a running swarm's nodes.
NOTHING_THERE = 10.0


def _swarm_nodes(node: SwarmNode, namespace: str) -> list[str]:
    """The names of the nodes under ``/namespace`` that ``node`` sees on the graph."""
    return [
        name
        for name, node_namespace in node.get_node_names_and_namespaces()
        if node_namespace.strip("/") == namespace
    ]


def compute_pose(
    namespace: str,
    source: int,
    target: int,
    policy: str,
    estimator: str,
    timeout: float,
    domain_id: int | None = None,
) -> Estimate:
    """The coordinator's answer to ComputePose, within ``timeout`` s; SwazureError otherwise.

    ``namespace`` is the swarm's ("" reads "swarm"); ``policy`` and ``estimator``
    are the names ``swazure query`` takes.
    """
    namespace = namespace.strip("/") or "swarm"
    service = f"/{namespace}/{COORDINATOR}/{COMPUTE_POSE_SERVICE}"
    context = init_context(domain_id)
    node = SwarmNode("swazure_query", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        client = node.create_client(ComputePose, service)
        began = time.monotonic()
        deadline = began + timeout
        while not client.service_is_ready():
            now = time.monotonic()
            if now > deadline or (
                now > began + min(timeout, NOTHING_THERE) and not _swarm_nodes(node, namespace)
            ):
                raise RunError(
                    f"no coordinator on domain {context.get_domain_id()}, namespace "
                    f"/{namespace} (no {service} in {now - began:.0f} s): is a swarm up? "
                    "(swazure spawn, or ros2 launch swazure_ros swarm.launch.py)"
                )
            executor.spin_once(timeout_sec=0.1)
        request = ComputePose.Request(
            source_id=source,
            target_id=target,
            policy=policy_code(policy),
            estimator=ESTIMATOR_CODES[estimator],
        )
        future: Any = client.call_async(request)
        while not future.done():
            if time.monotonic() > deadline:
                raise RunError(f"{service}: no answer within {timeout:g} s")
            executor.spin_once(timeout_sec=0.1)
        response = future.result()
        if not response.success:
            raise SwazureError(f"{service}: {response.message}")
        return pose_estimate_from_message(response.estimate)
    finally:
        executor.shutdown()
        node.destroy_node()  # type: ignore[no-untyped-call]
        context.try_shutdown()
