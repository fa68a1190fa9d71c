"""The coordinator's ``~/compute_pose`` (swazure_interfaces/ComputePose): one source's
search for one target, on demand.

The answer waits for a whole discovery run, and meanwhile the coordinator
keeps clocking: the service answers later (:mod:`.deferred`).
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.task import Future
from swazure_interfaces.msg import PoseEstimate
from swazure_interfaces.srv import ComputePose

from ...core.sensor import Sensor
from ...protocol.discovery.buckets import refusal
from ...protocol.runs import DiscoveryResult
from ..convert.discovery import pose_estimate_message
from ..plumbing.deferred import Reply, create_deferred_service
from ..plumbing.names import COMPUTE_POSE_SERVICE, ESTIMATOR_NAMES, POLICY_NAMES
from ..plumbing.node import SwarmNode

#: discover(policy, sources, targets, estimator): a future of the run's DiscoveryResult.
Discover = Callable[[str, list[int], list[int], str], Future]


def refused(message: str) -> ComputePose.Response:
    """A failed answer: ``message`` says why, and the estimate's status says there is none."""
    response = ComputePose.Response(success=False, message=message)
    response.estimate.status = PoseEstimate.STATUS_NONE
    return response


class PoseService:
    """Answers ComputePose for ``node`` by one discovery run of ``discover``.

    ``sensor`` and the FLSs' ``radius`` (cm) tell which policies the swarm can run;
    ``fls_ids`` are the swarm's FLSs, ``departed()`` those known gone.
    """

    def __init__(
        self,
        node: SwarmNode,
        sensor: Sensor,
        radius: float,
        fls_ids: frozenset[int],
        departed: Callable[[], frozenset[int]],
        discover: Discover,
    ) -> None:
        self.node = node
        self.sensor = sensor
        self.radius = radius
        self.fls_ids = fls_ids
        self.departed = departed
        self.discover = discover
        create_deferred_service(node, ComputePose, f"~/{COMPUTE_POSE_SERVICE}", self._on_request)

    def _on_request(self, request: ComputePose.Request, reply: Reply) -> None:
        source, target = int(request.source_id), int(request.target_id)
        problem = None
        if request.policy not in POLICY_NAMES:
            problem = f"unknown policy {request.policy}: expected one of {sorted(POLICY_NAMES)}"
        elif request.estimator not in ESTIMATOR_NAMES:
            problem = (
                f"unknown estimator {request.estimator}: expected one of {sorted(ESTIMATOR_NAMES)}"
            )
        elif (unusable := self._unusable(POLICY_NAMES[request.policy])) is not None:
            problem = unusable
        elif source == target:
            problem = f"source and target are both FLS {source}"
        else:
            for role, fls_id in (("source", source), ("target", target)):
                if fls_id not in self.fls_ids:
                    problem = f"no {role} FLS {fls_id} in this swarm of {len(self.fls_ids)} FLSs"
                    break
                if fls_id in self.departed():
                    problem = f"{role} FLS {fls_id} has departed"
                    break
        if problem is not None:
            reply(refused(problem))
            return
        estimator = ESTIMATOR_NAMES[request.estimator]
        run = self.discover(POLICY_NAMES[request.policy], [source], [target], estimator)
        run.add_done_callback(lambda done: reply(self._pose_answer(done.result(), source, target)))

    def _unusable(self, policy: str) -> str | None:
        """Why this swarm's FLSs cannot search by ``policy``; None when they can."""
        return refusal(self.sensor, self.radius, policy)

    def _pose_answer(
        self, result: DiscoveryResult, source: int, target: int
    ) -> ComputePose.Response:
        found = [one for one in result.outcome.estimates.get(source, []) if one.target == target]
        if not found:
            message = (
                f"FLS {target} is not a blind neighbour of FLS {source}: "
                "Swazure computes poses of blind neighbours only"
                if source in result.outcome.estimates
                else f"no answer from source FLS {source}"
            )
            return refused(message)
        stamp = self.node.get_clock().now().to_msg()
        return ComputePose.Response(
            success=True, estimate=pose_estimate_message(source, found[0], stamp)
        )
