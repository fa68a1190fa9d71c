"""Ask a running swarm for one source FLS's pose relative to one blind neighbour.

Calls /NAMESPACE/coordinator/compute_pose (swazure_interfaces/ComputePose):
the coordinator clocks one discovery run in which labels travel from FLS to
FLS (docs/protocol.md). Prints the status, the path and the estimated vector; with
``--estimator local-least-squares``, the source's fit and its standard deviations.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from ..core.evaluation import REASON_NAMES, STATUS_NAMES
from ..protocol.discovery.estimate import Estimate
from .arguments import fls_id, ros_namespace, seconds
from .options import add_domain_argument, add_policy_argument, add_swarm_estimator_argument


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure query``."""
    parser.add_argument("--source", type=fls_id, required=True, metavar="I", help="source FLS id")
    parser.add_argument("--target", type=fls_id, required=True, metavar="J", help="target FLS id")
    add_policy_argument(parser)
    add_swarm_estimator_argument(parser)
    parser.add_argument(
        "--namespace", type=ros_namespace, default="swarm", help="namespace of the swarm"
    )
    add_domain_argument(parser)
    parser.add_argument(
        "--timeout",
        type=seconds,
        default=60.0,
        metavar="S",
        help="give up after S seconds (default 60)",
    )


def describe(source: int, found: Estimate) -> str:
    """The lines ``swazure query`` prints for one estimate."""
    status = STATUS_NAMES[found.status]
    reason = f" ({REASON_NAMES[found.reason]})" if found.reason else ""
    lines = [f"FLS {source} -> FLS {found.target}: {status}{reason}"]
    if found.path:
        lines.append(f"path: {' -> '.join(str(fls) for fls in found.path)} ({found.hops} hops)")
        x, y, z = found.vector.tolist()
        norm = math.sqrt(x * x + y * y + z * z)
        lines.append(f"vector: ({x:.6f}, {y:.6f}, {z:.6f}) cm, |v| = {norm:.6f} cm")
        lines.append(f"path length: {found.length:.6f} cm")
        if found.covariance is not None:
            sigma = np.sqrt(np.diag(found.covariance))
            lines.append(
                f"{found.estimator}: standard deviation (x, y, z) "
                f"({sigma[0]:.6f}, {sigma[1]:.6f}, {sigma[2]:.6f}) cm, "
                f"sqrt(trace) {found.predicted_error:.6f} cm"
            )
    return "\n".join(lines)


def main(args: argparse.Namespace) -> int:
    """Run ``swazure query``."""
    from ..ros.clients.query import compute_pose

    found = compute_pose(
        args.namespace,
        args.source,
        args.target,
        args.policy,
        args.estimator,
        args.timeout,
        args.domain_id,
    )
    print(describe(args.source, found))
    return 0
