"""Liveness from the real ROS graph: an FLS node gone for the grace, on the looker's clock."""

from __future__ import annotations

from swazure_ros.ros.plumbing.liveness import FlsLiveness

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
