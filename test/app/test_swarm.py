"""app.swarm: RunningSwarm.start gives a swarm back up and discovered, or stops what came up.

The whole swarm's runs over DDS are tested in test/ros (test_discovery, test_launcher,
...), every one through RunningSwarm.start; here, what starting promises besides.
"""

from __future__ import annotations

import pytest

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm, Starting
from swazure_ros.core.errors import RunError
from swazure_ros.sim.world import WorldSpec

WORLD = WorldSpec("torus:120", scale=1.6, beta=0.5)


def test_a_started_swarm_is_up_and_discovered_and_left_stopped(domain):
    starts: list[Starting] = []
    created: list[tuple[int, int]] = []

    def on_starting(starting: Starting) -> None:
        # Told once the host is made, before any FLS node: a Ctrl-C handler can use it.
        assert starting.context.ok() and not starting.host.fls_nodes
        starts.append(starting)

    config = SwarmConfig(WORLD, domain_id=domain)
    with RunningSwarm.start(
        config, lambda done, total: created.append((done, total)), on_starting=on_starting
    ) as swarm:
        # Running: every FLS node of the swarm, its coordinator, its bring-up measured.
        assert [one.host for one in starts] == [swarm.host]
        assert len(swarm.host.fls_nodes) == swarm.size == 120
        assert swarm.coordinator is not None and swarm.bring_up.flss == 120
        assert swarm.bring_up.seconds > 0 and created[-1] == (120, 120)
        assert swarm.recorder is None and swarm.view is None  # none asked for
    assert not swarm.context.ok() and not swarm.host.nodes


def test_a_swarm_not_discovered_in_time_is_measured_before_it_stops(domain):
    """Share 0 of two hosts whose share 1 never comes: never discovered."""
    failed: list[tuple[bool, int, str]] = []
    starts: list[Starting] = []

    def on_failed(starting: Starting, err: Exception) -> None:
        # Still running when told: what the bring-up took can be measured.
        failed.append((starting.context.ok(), len(starting.host.fls_nodes), str(err)))

    config = SwarmConfig(WORLD, domain_id=domain, hosts=2, discovery_timeout=5.0)
    with pytest.raises(RunError, match="swarm not discovered after 5 s"):
        RunningSwarm.start(config, on_starting=starts.append, on_failed=on_failed)
    assert [(ok, nodes) for ok, nodes, _ in failed] == [(True, 60)]
    assert failed[0][2].startswith("swarm not discovered")
    # Then stopped: nothing of it is left running.
    assert not starts[0].context.ok() and not starts[0].host.nodes


def test_a_start_interrupted_by_ctrl_c_stops_what_came_up_and_is_no_failure(domain):
    starts: list[Starting] = []
    failed: list[Exception] = []

    def interrupt(created: int, total: int) -> None:
        raise KeyboardInterrupt

    config = SwarmConfig(WORLD, domain_id=domain)
    with pytest.raises(KeyboardInterrupt):
        RunningSwarm.start(
            config,
            interrupt,
            on_starting=starts.append,
            on_failed=lambda starting, err: failed.append(err),
        )
    assert failed == []
    assert not starts[0].context.ok() and not starts[0].host.nodes
