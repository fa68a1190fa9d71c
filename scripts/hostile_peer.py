"""A hostile peer on a swarm's ROS domain, for the hostile-peer soak (bench/hostile.py).

For SECONDS seconds it publishes, on every topic of the swarm, messages
generated from each type's field list (test/ros/fuzz.py) and forged offers
answering every round the coordinator clocks, with the live run's id, the
sender a target's, a path over a blind pair and the vector [123, 456, 789],
unsigned and under a key of its own. It prints what it sent as JSON.

    python scripts/hostile_peer.py DOMAIN SECONDS [RATE]
"""

from __future__ import annotations

import contextlib
import json
import sys
import time
from collections import Counter
from pathlib import Path

from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from swazure_interfaces.msg import (
    Departed,
    DiscoveryControl,
    Measurements,
    MoveCommands,
    PathOffer,
    PathWalk,
    PoseEstimates,
    RoundAck,
    TrackRequest,
    TrackSample,
    WorldState,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from swazure_ros.ros.plumbing import names
from swazure_ros.ros.plumbing.process import init_context
from swazure_ros.ros.security.auth import SwarmKey, new_key
from test.ros.fuzz import message, well_formed_offer

TOPICS = {
    names.CONTROL_TOPIC: (DiscoveryControl, names.ROUND_QOS),
    names.RADIO_TOPIC: (PathOffer, names.ROUND_QOS),
    names.ESTIMATES_TOPIC: (PoseEstimates, names.ROUND_QOS),
    names.ACK_TOPIC: (RoundAck, names.ROUND_QOS),
    names.WALKS_TOPIC: (PathWalk, names.ROUND_QOS),
    names.WORLD_TOPIC: (WorldState, names.WORLD_QOS),
    names.MOVE_TOPIC: (MoveCommands, names.MOVE_QOS),
    names.TRACK_REQUESTS_TOPIC: (TrackRequest, names.ROUND_QOS),
    names.TRACK_SAMPLES_TOPIC: (TrackSample, names.ROUND_QOS),
    names.DEPARTED_TOPIC: (Departed, names.DEPARTED_QOS),
    names.MEASUREMENTS_TOPIC: (Measurements, names.MEASUREMENTS_QOS),
}


class TimeUpError(Exception):
    """The soak's time is up."""


def main() -> int:
    domain, seconds = int(sys.argv[1]), float(sys.argv[2])
    rate = float(sys.argv[3]) if len(sys.argv) > 3 else 200.0
    context = init_context(domain)
    node = Node("hostile_peer", namespace="swarm", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    publishers = {
        topic: node.create_publisher(kind, topic, qos) for topic, (kind, qos) in TOPICS.items()
    }
    keys = [SwarmKey(), SwarmKey(new_key())]  # unsigned, and signed with a key of its own
    sent: Counter[str] = Counter()
    live: dict[str, int] = {}

    def on_control(control: DiscoveryControl) -> None:
        live["run"], live["round"], live["phase"] = control.run_id, control.round, control.phase

    node.create_subscription(DiscoveryControl, names.CONTROL_TOPIC, on_control, names.ROUND_QOS)
    ids = [0, 1, 2, 100, 407, 408, 2**32 - 1]
    strategies = [
        st.tuples(st.just(topic), message(kind, ids)) for topic, (kind, _) in TOPICS.items()
    ]
    strategies.append(st.tuples(st.just(names.RADIO_TOPIC), well_formed_offer(PathOffer, ids)))
    deadline = time.monotonic() + seconds

    def forged(key: SwarmKey) -> None:
        if "run" not in live:
            return
        offer = PathOffer(
            run_id=live["run"], phase=live["phase"], round=live["round"], sender_id=1,
            source_ids=[0], hops=[1], lengths=[7.0], errors=[0.1],
            vectors=[123.0, 456.0, 789.0], path_offsets=[0, 2], path_ids=[0, 1],
        )  # fmt: skip
        publishers[names.RADIO_TOPIC].publish(key.serialize(offer))
        sent["forged offers"] += 1

    @settings(
        max_examples=10**9,
        deadline=None,
        database=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(pick=st.one_of(strategies), key=st.sampled_from(keys))
    def flood(pick: tuple[str, object], key: SwarmKey) -> None:
        if time.monotonic() > deadline:
            raise TimeUpError
        topic, generated = pick
        signed = hasattr(generated, "auth")  # measurements are for people: never signed
        publishers[topic].publish(key.serialize(generated) if signed else generated)
        sent[topic] += 1
        forged(key)
        executor.spin_once(timeout_sec=1.0 / rate)

    with contextlib.suppress(TimeUpError):
        flood()
    print(json.dumps(dict(sent)))
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
