"""A person's questions to a swarm (swazure_ros.ros.clients.query) against real services."""

from __future__ import annotations

import pytest
from rclpy.executors import SingleThreadedExecutor
from swazure_interfaces.srv import GetNeighbours

from swazure_ros.ros.clients import query
from swazure_ros.ros.clients.query import SwarmQueries
from swazure_ros.ros.plumbing.deferred import create_deferred_service
from swazure_ros.ros.plumbing.node import SwarmNode

from ...waits import PATIENCE


@pytest.fixture
def forgetful_fls(context):
    """FLS 3's GetNeighbours, whose first answer is lost (never sent), as a reply is when
    the asker's reader is not matched in time; every later request is answered, blind
    neighbours 4 and 5. Yields (the requests heard, what serves it)."""
    node = SwarmNode("fls_3", namespace="/swarm", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    heard: list[int] = []

    def on_request(request, reply) -> None:
        heard.append(int(request.fls_id))
        if len(heard) > 1:
            reply(GetNeighbours.Response(success=True, blind_ids=[4, 5]))

    create_deferred_service(node, GetNeighbours, "~/get_neighbours", on_request)
    try:
        yield heard, lambda: executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        node.destroy_node()


def test_a_neighbours_question_whose_answer_is_lost_is_asked_again(
    domain, forgetful_fls, monkeypatch
):
    heard, serve = forgetful_fls
    monkeypatch.setattr(query, "ASK_AGAIN", 0.5)  # seconds, not the person's 5
    with SwarmQueries("swarm", domain, step=serve) as queries:
        answer = queries.neighbours(3, PATIENCE)
    assert answer.blind == (4, 5) and answer.fls_id == 3, answer
    assert len(heard) >= 2 and set(heard) == {3}, heard
