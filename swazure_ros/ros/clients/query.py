"""Ask a running swarm: its coordinator for one source FLS's pose relative to a target, an
FLS for its neighbours (the FLS itself, or the host node of its process where hosts answer
for their FLSs: ``spawn --neighbour-services``)."""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from rclpy.executors import SingleThreadedExecutor
from swazure_interfaces.srv import ComputePose, GetNeighbours

from ...core.errors import RunError, SwazureError
from ...protocol.discovery.estimate import Estimate
from ..convert.discovery import pose_estimate_from_message
from ..plumbing.names import (
    COMPUTE_POSE_SERVICE,
    COORDINATOR,
    ESTIMATOR_CODES,
    NEIGHBOURS_SERVICE,
    node_name,
    policy_code,
)
from ..plumbing.node import SwarmNode
from ..plumbing.process import init_context

#: Seconds after which a query that sees no node of the swarm at all gives up, whatever
#: its timeout: a swarm that is coming up shows its nodes long before its coordinator.
#: Not less: a loaded 2-core machine took over 3 s to discover a running swarm's nodes.
NOTHING_THERE = 10.0
#: Seconds a question that is answered at once (GetNeighbours) waits before it asks
#: again, doubled each time. A response can be lost while both ends still match: the
#: server's reply waits a moment for the asker's reader and is dropped without it
#: (ros2/system_tests#420; a loaded CI machine's `ros2 param get` waited for one for
#: good). The answer is the same each time, so asking again costs a slow FLS little.
ASK_AGAIN = 5.0


def _swarm_nodes(node: SwarmNode, namespace: str) -> list[str]:
    """The names of the nodes under ``/namespace`` that ``node`` sees on the graph."""
    return [
        name
        for name, node_namespace in node.get_node_names_and_namespaces()
        if node_namespace.strip("/") == namespace
    ]


@dataclass(frozen=True)
class Neighbours:
    """One FLS's neighbours as it knows them (GetNeighbours), as sorted FLS ids."""

    fls_id: int
    blind: tuple[int, ...]  # by radio
    sweet: tuple[int, ...]  # sweet range, by radio (line of sight ignored)
    visible_sweet: tuple[int, ...]  # sweet range with line of sight
    decaying: tuple[int, ...]  # decaying range with line of sight
    gone: tuple[int, ...]  # of those, the ones whose nodes left the ROS graph


class SwarmQueries:
    """A person's questions to a running swarm, over one node of its own context.

    ComputePose of the coordinator and GetNeighbours of an FLS, each answer
    waited for within a timeout. ``close`` (or leaving the ``with`` block)
    destroys the node and shuts the context down.
    """

    def __init__(
        self,
        namespace: str,
        domain_id: int | None = None,
        step: Callable[[], object] | None = None,
    ) -> None:
        self.namespace = namespace.strip("/") or "swarm"
        #: Called between the client's spins while it waits: what serves a swarm that
        #: this process runs itself (its own executor), so that it can answer.
        self.step = step
        self.context = init_context(domain_id)
        self.node = SwarmNode("swazure_query", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients: dict[str, Any] = {}

    def __enter__(self) -> SwarmQueries:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Destroy the node and shut its context down; nothing of it is left running."""
        self.executor.shutdown()
        self.node.destroy_node()  # type: ignore[no-untyped-call]
        self.context.try_shutdown()

    def _call(
        self,
        kind: Any,
        service: str,
        who: str,
        request: Any,
        timeout: float,
        ask_again: float | None = None,
    ) -> Any:
        """``request``'s response from ``service`` within ``timeout`` s; RunError otherwise.

        Gives up early, whatever the timeout, when no node of the swarm shows at all
        (NOTHING_THERE): ``who`` names what did not answer. With ``ask_again`` (s), a
        request not answered by then is sent again, then after twice as long, and so
        on: the first answer to any of them is taken (for a request whose answer is the
        same each time, and cheap: not a discovery run).
        """
        client = self._clients.get(service)
        if client is None:
            client = self._clients[service] = self.node.create_client(kind, service)
        deadline = time.monotonic() + timeout
        self._wait(client.service_is_ready, who, service, timeout)
        futures: list[Any] = [client.call_async(request)]
        period = math.inf if ask_again is None else ask_again
        again = time.monotonic() + period
        try:
            while not any(future.done() for future in futures):
                now = time.monotonic()
                if now > deadline:
                    raise RunError(f"{service}: no answer within {timeout:g} s")
                if now > again:
                    futures.append(client.call_async(request))
                    period *= 2
                    again = now + period
                self._spin()
            return next(future for future in futures if future.done()).result()
        finally:
            for future in futures:
                if not future.done():  # a late answer to it is dropped (rclpy)
                    client.remove_pending_request(future)

    def _wait(self, ready: Callable[[], object], who: str, what: str, timeout: float) -> None:
        """Spin until ``ready()``; RunError naming ``who`` and ``what`` after ``timeout`` s.

        Gives up early, whatever the timeout, when no node of the swarm shows at all
        (NOTHING_THERE).
        """
        began = time.monotonic()
        while not ready():
            now = time.monotonic()
            if now > began + timeout or (
                now > began + min(timeout, NOTHING_THERE)
                and not _swarm_nodes(self.node, self.namespace)
            ):
                raise RunError(
                    f"no {who} on domain {self.context.get_domain_id()}, namespace "
                    f"/{self.namespace} (no {what} in {now - began:.0f} s): is a swarm up? "
                    "(swazure spawn, or ros2 launch swazure_ros swarm.launch.py)"
                )
            self._spin()

    def _spin(self) -> None:
        if self.step is None:
            self.executor.spin_once(timeout_sec=0.1)
        else:
            self.executor.spin_once(timeout_sec=0.01)
            self.step()

    def compute_pose(
        self, source: int, target: int, policy: str, estimator: str, timeout: float
    ) -> Estimate:
        """The coordinator's answer to ComputePose, within ``timeout`` s; SwazureError otherwise.

        ``policy`` and ``estimator`` are the names ``swazure query`` takes.
        """
        service = f"/{self.namespace}/{COORDINATOR}/{COMPUTE_POSE_SERVICE}"
        request = ComputePose.Request(
            source_id=source,
            target_id=target,
            policy=policy_code(policy),
            estimator=ESTIMATOR_CODES[estimator],
        )
        response = self._call(ComputePose, service, COORDINATOR, request, timeout)
        if not response.success:
            raise SwazureError(f"{service}: {response.message}")
        return pose_estimate_from_message(response.estimate)

    def neighbours(self, fls_id: int, timeout: float) -> Neighbours:
        """FLS ``fls_id``'s answer to GetNeighbours in ``timeout`` s; SwazureError otherwise.

        Asked of the FLS's own service where it has one, else of each host node's in
        name order until the one that hosts it answers (the same answer).
        """
        deadline = time.monotonic() + timeout
        own = f"/{self.namespace}/{node_name(fls_id)}/{NEIGHBOURS_SERVICE}"
        hosts = re.compile(rf"^/{re.escape(self.namespace)}/host_\d+/{NEIGHBOURS_SERVICE}$")
        request = GetNeighbours.Request(fls_id=fls_id)
        who = f"FLS {fls_id}"
        asked: set[str] = set()
        unasked: list[str] = []

        def more() -> bool:
            # Hosts come onto the graph one by one: one not seen yet may host it.
            names = {name for name, _ in self.node.get_service_names_and_types()}
            unasked[:] = [own] if own in names else sorted(set(filter(hosts.match, names)) - asked)
            return bool(unasked)

        response = None
        while response is None:
            left = deadline - time.monotonic()
            self._wait(more, who, f"{own}, nor a host node that hosts it", left)
            response = self._first_answer(unasked, own, request, who, deadline)
            asked.update(unasked)
        ids = {
            name: tuple(int(one) for one in getattr(response, f"{name}_ids"))
            for name in ("blind", "sweet", "visible_sweet", "decaying", "gone")
        }
        return Neighbours(fls_id, **ids)

    def _first_answer(
        self,
        services: list[str],
        own: str,
        request: GetNeighbours.Request,
        who: str,
        deadline: float,
    ) -> GetNeighbours.Response | None:
        """The first of ``services``' answers that succeeds; None if none does.

        SwazureError where the FLS's own service (``own``) refuses: it speaks for itself.
        """
        for service in services:
            left = max(deadline - time.monotonic(), 0.0)
            response = self._call(GetNeighbours, service, who, request, left, ASK_AGAIN)
            if response.success:
                return response
            if service == own:
                raise SwazureError(f"{service}: {response.message}")
        return None


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
    with SwarmQueries(namespace, domain_id) as queries:
        return queries.compute_pose(source, target, policy, estimator, timeout)
