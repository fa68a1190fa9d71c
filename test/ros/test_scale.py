"""A swarm of a thousand FLS nodes in one process, in CI time: up, latched, poses exact.

The whole swarm's discovery at this size (291,372 ordered blind pairs, about
3 minutes here) is in `make bench`; this test asks the swarm for a few pairs.
"""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from swazure_interfaces.msg import Measurements

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate
from swazure_ros.ros.convert.measurements import read_measurements
from swazure_ros.sim.world import WorldSpec

from ..waits import PATIENCE, wait_until
from .helpers import LATCHED

# A thousand FLSs at the published density; every one its own rclpy node.
WORLD = WorldSpec("sphere:1000", beta=0.5)


@pytest.fixture
def params(tmp_path):
    path = tmp_path / "swarm.yaml"
    path.write_text("/**/coordinator:\n  ros__parameters:\n    round_timeout: 30.0\n")
    return path


def test_a_thousand_node_swarm_comes_up_latches_and_computes_the_engines_poses(
    domain, params, context
):
    config = SwarmConfig(WORLD, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        bring_up = swarm.bring_up
        world = swarm.world
        assert bring_up.flss == len(world.ids) >= 1000
        # A reader that joins now gets every FLS's latched measurement.
        probe = Node("probe", context=context, start_parameter_services=False)
        heard = set()
        # Read as bytes, as the swarm's own radios do: rclpy makes a message object of
        # hundreds of poses in 0.1 s, minutes for a thousand.
        probe.create_subscription(
            Measurements,
            "/swarm/measurements",
            lambda data: heard.add(read_measurements(data).source_id),
            LATCHED,
            raw=True,
        )
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(probe)

        def spin_both():
            swarm.spin(0.01)
            for _ in range(200):  # one callback per spin_once: drain the backlog
                executor.spin_once(timeout_sec=0.0)

        assert wait_until(lambda: len(heard) == len(world.ids), PATIENCE, spin_both), len(heard)
        executor.shutdown()
        probe.destroy_node()
        engine = evaluate(world.swarm, world.sensor, "shortest-length").pairs
        ids = world.ids
        far = np.flatnonzero(engine.hops >= 2)
        asked = far[np.linspace(0, len(far) - 1, 6).astype(np.int64)]
        sources = [int(ids[engine.source[pair]]) for pair in asked]
        targets = [int(ids[engine.target[pair]]) for pair in asked]
        run = swarm.coordinator.discover("shortest-length", sources, targets)
        result = swarm.run(run, timeout=300)
        assert result.outcome.departed == frozenset() and len(asked) >= 5
        for pair, source, target in zip(asked, sources, targets, strict=True):
            (found,) = [one for one in result.outcome.estimates[source] if one.target == target]
            assert found.path == tuple(int(ids[k]) for k in engine.path(pair))
            np.testing.assert_allclose(found.vector, engine.estimate[pair], rtol=0, atol=1e-9)
