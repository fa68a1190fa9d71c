"""A process's radio over real DDS: who it must be heard by before it takes part."""

from __future__ import annotations

from swazure_ros.files.description import SwarmDescription
from swazure_ros.protocol.senses import DetectedSenses
from swazure_ros.ros.nodes.radio import Radio
from swazure_ros.ros.plumbing.node import SwarmNode

from ...conftest import REPO
from ...waits import PATIENCE, wait_until
from ..conftest import make_context

# Three FLSs in one radio cell of each band: each hears the other two.
TRIO = SwarmDescription(cloud=str(REPO / "config/track/trio.xyz"), scale=1.0, radius=0.5)


def fls_radio(context: object, fls_id: int) -> tuple[SwarmNode, Radio]:
    """FLS ``fls_id`` of the trio alone in its process (its own participant), with its radio."""
    assigned = TRIO.assigned()
    senses = DetectedSenses(
        fls_id, assigned.cloud_index, assigned.points, TRIO.sensor(), assigned.radius
    )
    node = SwarmNode(f"fls_{fls_id}", namespace="swarm", context=context)
    return node, Radio(node, senses, {}, listen=False, local=[fls_id])


def test_an_fls_is_not_heard_by_every_neighbour_while_one_is_missing(domain):
    """FLS 0 and FLS 1 run, FLS 2 does not: FLS 0's radio must not count itself for FLS 2.

    It reads its own cell, so its own reader matches its own writer: that reader
    is one more wanted, not one of its neighbours'.
    """
    from rclpy.executors import SingleThreadedExecutor

    contexts = [make_context(domain), make_context(domain)]
    (node, radio), (other, _) = (fls_radio(ctx, fls) for ctx, fls in zip(contexts, (0, 1)))
    executor = SingleThreadedExecutor(context=contexts[0])
    executor.add_node(node)
    try:
        # It sends offers on its sweet and decaying cells and walks on its walks cell; each
        # has two readers now, its own and FLS 1's, and wants three.
        assert wait_until(
            lambda: radio.cell_readers()[0] == 6, PATIENCE, lambda: executor.spin_once(0.1)
        )
        assert radio.cell_readers() == (6, 9)  # FLS 2's readers are missing
        for _ in range(10):
            executor.spin_once(0.1)
        assert radio.cell_readers() == (6, 9)
    finally:
        executor.shutdown()
        node.destroy_node()
        other.destroy_node()
        for ctx in contexts:
            ctx.try_shutdown()
