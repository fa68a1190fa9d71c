"""Services that answer later, on an executor that cannot await in callbacks.

rclpy 7.1's EventsExecutor, which spins a process's FLS nodes, calls a
service callback and sends what it returns at once; an ``async`` callback is
never awaited (ros2/rclpy#1473, fixed upstream in #1478, after the Jazzy
wheels this project pins). The coordinator's ``compute_pose`` (one source's
pose relative to a target) must wait for a whole discovery run of the swarm,
so the service answers later: the executor hands the request header to
``send_response``, and that is where we keep it until the answer is ready.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.service import Service

#: reply(response) sends the answer to one request; call it once.
Reply = Callable[[Any], None]


def create_deferred_service(
    node: Node, srv_type: Any, name: str, on_request: Callable[[Any, Reply], None]
) -> Service:
    """A service of ``node`` whose ``on_request(request, reply)`` answers by calling reply."""
    waiting: dict[int, tuple[Any, Any]] = {}  # id(placeholder) -> (placeholder, request)

    def take(request: Any, placeholder: Any) -> Any:
        waiting[id(placeholder)] = (placeholder, request)
        return placeholder

    service = node.create_service(srv_type, name, take)
    send = service.send_response

    def send_response(response: Any, header: Any) -> None:
        entry = waiting.pop(id(response), None)
        if entry is None or entry[0] is not response:
            send(response, header)
            return
        on_request(entry[1], lambda answer: send(answer, header))

    service.send_response = send_response  # type: ignore[method-assign]
    return service
