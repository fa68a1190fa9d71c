"""Liveness from the real ROS graph: an FLS node gone for the grace, on the looker's clock."""

from __future__ import annotations

import pytest

from swazure_ros.ros.plumbing import liveness as liveness_module
from swazure_ros.ros.plumbing.liveness import LOOK_SHARE, FlsLiveness, look_interval

from ...waits import PATIENCE, wait_until
from ..conftest import make_context


def test_an_fls_node_off_the_graph_is_gone_after_the_grace_on_the_lookers_clock(domain):
    """The grace runs on the clock the looker gives: a coordinator's leaves its own stalls
    out, so that an FLS is not counted absent while the coordinator could not look."""
    from rclpy.node import Node

    looker_context, fls_context = make_context(domain), make_context(domain)
    looker = Node("coordinator", namespace="swarm", context=looker_context)
    fls = Node("fls_3", namespace="swarm", context=fls_context)
    liveness = FlsLiveness(looker, "swarm", grace=2.0)
    try:
        assert wait_until(lambda: (liveness.look(set(), 0.0), 3 in liveness.seen)[1], PATIENCE)
        fls.destroy_node()
        fls_context.try_shutdown()
        assert wait_until(
            lambda: ("fls_3", "/swarm") not in looker.get_node_names_and_namespaces(), 60
        )
        # Off the graph from 100 s on the looker's clock: gone once it has been for 2 s.
        assert liveness.look(set(), 100.0) == set()
        assert liveness.look(set(), 101.9) == set()
        assert liveness.look(set(), 102.0) == {3}
        assert liveness.look({3}, 110.0) == set()  # known gone already
    finally:
        looker.destroy_node()
        looker_context.try_shutdown()
        fls_context.try_shutdown()


@pytest.mark.parametrize(
    ("look_seconds", "grace", "interval"),
    [
        (0.0005, 2.0, 0.0005 / LOOK_SHARE),  # a small swarm: looked at as often as asked
        (0.03, 2.0, 0.03 / LOOK_SHARE),  # torus:30000's graph: a look every 1.5 s
        (0.1, 2.0, 2.0),  # never less often than the grace: a gone FLS seen within 3x
        (0.03, 0.0, 0.0),  # no grace: every tick looks
    ],
)
def test_a_look_that_takes_longer_is_made_less_often_up_to_the_grace(
    look_seconds, grace, interval
):
    assert look_interval(look_seconds, grace) == pytest.approx(interval)


def test_a_look_is_not_due_again_until_its_interval_has_passed(domain, monkeypatch):
    from rclpy.node import Node

    # Every look as costly as can be: the next waits the whole grace (5 s).
    monkeypatch.setattr(liveness_module, "LOOK_SHARE", 1e-12)
    context = make_context(domain)
    looker = Node("coordinator", namespace="swarm", context=context)
    liveness = FlsLiveness(looker, "swarm", grace=5.0)
    try:
        assert liveness.due()  # never looked
        liveness.look(set())
        assert not liveness.due()
        assert wait_until(liveness.due, PATIENCE)
    finally:
        looker.destroy_node()
        context.try_shutdown()
