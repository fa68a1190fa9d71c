"""SwarmHost over real DDS: taking a node out of a process's executor mid-run."""

from __future__ import annotations

import time

from rclpy.node import Node

from swazure_ros.ros.programs.host import HostConfig, SwarmHost
from swazure_ros.sim.world import WorldSpec

from ...waits import wait_until


def test_a_node_removed_while_its_timer_events_wait_runs_them_alive_then_leaves_the_graph(context):
    world = WorldSpec("helix:10", beta=0.5).build()
    calls: list[tuple[str, int]] = []
    with SwarmHost(world, HostConfig(tuple(world.ids)), context=context) as host:
        nodes = []
        for name in ("first", "second", "third"):
            node = Node(name, context=context, start_parameter_services=False)
            # Each call asks its own node for the graph: a destroyed node raises InvalidHandle.
            node.create_timer(
                0.01, lambda node=node: calls.append((node.get_name(), len(node.get_node_names())))
            )
            host.add(node)
            nodes.append(node)
        time.sleep(0.05)  # every timer is due: the executor queues all three events at once
        host.spin_once(0.1)  # runs one of them; the other two stay queued
        ran = {name for name, _ in calls}
        removed = next(node for node in nodes if node.get_name() not in ran)
        name = removed.get_name()
        host.remove(removed)
        observer = next(node for node in nodes if node is not removed)
        wait_until(
            lambda: name not in observer.get_node_names(), step=lambda: host.spin_once(0.05)
        )
        assert name not in observer.get_node_names()
        host.spin_for(0.2)
        assert removed not in host.nodes
        # The events queued before the removal ran while the node was alive, none after.
        assert all(seen >= 1 for _, seen in calls)


def test_a_node_removed_just_before_the_host_closes_leaves_the_graph(context):
    world = WorldSpec("helix:10", beta=0.5).build()
    observer = Node("observer", context=context, start_parameter_services=False)
    try:
        with SwarmHost(world, HostConfig(tuple(world.ids)), context=context) as host:
            node = Node("removed_last", context=context, start_parameter_services=False)
            host.add(node)
            host.remove(node)  # nothing spins after: closing must destroy it
        wait_until(lambda: "removed_last" not in observer.get_node_names())
        assert "removed_last" not in observer.get_node_names()
    finally:
        observer.destroy_node()
