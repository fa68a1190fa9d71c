"""A swarm's discovery run, recorded: the fixture and helpers of the recording tests."""

from __future__ import annotations

from collections import defaultdict
from functools import partial

import pytest
from swazure_interfaces.msg import PathOffer

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.ros.plumbing.names import ROUND_QOS
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.recording.reader import read_recording
from swazure_ros.sim.world import WorldSpec

from ...waits import PATIENCE, wait_until
from ..helpers import joined, radio_topics

#: The swarm of every recorded run.
WORLD = WorldSpec("helix:60", beta=0.5)
#: The protocol's topics of a discovery run, as the coordinator counts them.
RUN_TOPICS = ("estimates", "round_acks", "discovery")
RADIO = radio_topics(WORLD)


class Probe:
    """A raw subscriber to some topics of the swarm, keeping every message's bytes."""

    def __init__(self, context, topics):
        self.node = SwarmNode("probe", context=context)
        self.received = defaultdict(list)
        self.subscriptions = [
            self.node.create_subscription(kind, topic, partial(self._on, topic), qos, raw=True)
            for topic, kind, qos in topics
        ]

    def matched(self) -> bool:
        """Every subscription is matched to a publisher: what is sent now reaches it."""
        return all(one.get_publisher_count() >= 1 for one in self.subscriptions)

    def _on(self, topic, data):
        self.received[topic].append(data)


def recorded_messages(path):
    received = defaultdict(list)
    for message in read_recording(path):
        received[message.topic].append(message.data)
    return received


@pytest.fixture
def recorded_run(domain, tmp_path):
    """A helix swarm's discovery, recorded; with what a probe heard and the run's traffic."""
    path = tmp_path / "run"
    config = SwarmConfig(WORLD, domain_id=domain, record=str(path))
    with RunningSwarm.start(config) as swarm:
        probe = Probe(swarm.context, [(topic, PathOffer, ROUND_QOS) for topic in RADIO])
        swarm.host.add(probe.node)
        assert wait_until(probe.matched, PATIENCE, lambda: swarm.spin(0.05))
        result = swarm.discover("shortest-length", timeout=PATIENCE)
        # The run's last messages reach every reader, and every FLS's latched measurement
        # the recorder, however late its publisher matched.
        recorder = swarm.recorder
        assert recorder is not None

        def missing() -> dict[str, int]:
            offers = result.traffic.messages["radio"]
            return {
                "offers the probe lacks": offers - len(joined(probe.received, RADIO)),
                "offers the recorder lacks": offers
                - sum(recorder.counts.get(topic, 0) for topic in RADIO),
                "measurements the recorder lacks": len(swarm.world.ids)
                - recorder.counts.get("/swarm/measurements", 0),
            }

        arrived = wait_until(
            lambda: max(missing().values()) <= 0, PATIENCE, lambda: swarm.spin(0.05)
        )
        assert arrived, f"after {PATIENCE:.0f} s: {missing()}"
        # Still recording: nothing is at the path until the swarm stops.
        assert not path.exists()
    return path, probe.received, result, swarm.world
