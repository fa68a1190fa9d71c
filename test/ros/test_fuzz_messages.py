"""Generated messages of every type thrown at the handlers of a running swarm.

Each handler is called as its subscription would call it, through its
process's guard, with messages drawn from the type's own field list
(:mod:`.fuzz`): wrong lengths, unknown ids and codes, NaN and infinities,
ids of 2**32 - 1. The property: the guard counts each as taken or dropped
and not one raises past a check (``internal`` stays 0); afterwards a new
discovery run gives exactly the engine's answers. The handlers are called
directly, past the swarm's key: these are messages that a peer holding the
key could send, so the checks behind the key are what is tested.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message
from swazure_interfaces.msg import (
    DiscoveryControl,
    Heartbeat,
    MoveCommands,
    PathOffer,
    PathWalk,
    PoseEstimates,
    RoundAck,
    TrackRequest,
    TrackSample,
    WorldState,
)

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.ros.plumbing.names import (
    ACK_TOPIC,
    CONTROL_TOPIC,
    ESTIMATES_TOPIC,
    HEARTBEAT_TOPIC,
    MOVE_TOPIC,
    RADIO_TOPIC,
    TRACK_REQUESTS_TOPIC,
    TRACK_SAMPLES_TOPIC,
    WALKS_TOPIC,
    WORLD_TOPIC,
)
from swazure_ros.ros.security.guard import INTERNAL
from swazure_ros.sim.world import WorldSpec

from ..conftest import FUZZ
from .fuzz import message, well_formed_offer
from .test_discovery import assert_matches_engine, by_pair

POLICY = "shortest-length"
#: Generated messages per test: each handler gets a few hundred (the run is bounded in time).
EXAMPLES = 1500


def fls_ids(world) -> list[int]:
    ids = world.ids.tolist()
    return [ids[0], ids[1], ids[len(ids) // 2], ids[-1], ids[-1] + 1]


def test_generated_messages_stop_nothing_and_change_no_later_answer(domain, tmp_path):
    params = tmp_path / "swarm.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    publish_period: 5.0\n"
        "/**/coordinator:\n  ros__parameters:\n    round_timeout: 1.0\n"
    )
    spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    config = SwarmConfig(spec, domain_id=domain, params_file=str(params), authenticate=False)
    with RunningSwarm.start(config) as swarm:
        host, coordinator = swarm.host, swarm.coordinator
        radio, ids = host.radio, fls_ids(swarm.world)
        # A run under way, so that messages naming it reach the coordinator's clock.
        under_way = coordinator.discover(POLICY)
        live = coordinator.runs.running().run_id
        ids_and_runs = [*ids, live]

        def raw(handler):
            return lambda generated: handler(bytes(serialize_message(generated)))

        targets = [
            (CONTROL_TOPIC, message(DiscoveryControl, ids_and_runs), radio._on_control, host),
            (RADIO_TOPIC, message(PathOffer, ids_and_runs), radio._on_offer, host),
            (RADIO_TOPIC, well_formed_offer(PathOffer, ids), radio._on_offer, host),
            (WALKS_TOPIC, message(PathWalk, ids_and_runs), radio._on_walk, host),
            (TRACK_REQUESTS_TOPIC, message(TrackRequest, ids), radio._on_track_request, host),
            (TRACK_SAMPLES_TOPIC, message(TrackSample, ids), radio._on_track_sample, host),
            (ACK_TOPIC, message(RoundAck, ids_and_runs), raw(coordinator._on_ack), coordinator),
            (
                HEARTBEAT_TOPIC,
                message(Heartbeat, ids_and_runs),
                coordinator._on_heartbeat,
                coordinator,
            ),
            (
                ESTIMATES_TOPIC,
                message(PoseEstimates, ids_and_runs),
                raw(coordinator._on_estimates),
                coordinator,
            ),
        ]
        tried = []

        @settings(FUZZ, max_examples=EXAMPLES)
        @given(data=st.data())
        def throw(data):
            topic, strategy, handler, node = data.draw(st.sampled_from(targets))
            node.guard.call(topic, handler, data.draw(strategy))
            tried.append(topic)
            assert node.guard.dropped[(topic, INTERNAL)] == 0, node.guard.dropped

        throw()
        assert len(tried) == EXAMPLES
        taken = sum(host.guard.accepted.values()) + sum(coordinator.guard.accepted.values())
        dropped = host.guard.total_dropped + coordinator.guard.total_dropped
        print(f"\n{len(tried)} generated messages: {taken} taken, {dropped} dropped")
        print(dict(host.guard.dropped), dict(coordinator.guard.dropped))
        assert dropped > EXAMPLES / 2 and taken > 50

        # The run the messages were aimed at ends by its deadlines, whatever it made of them.
        try:
            swarm.run(under_way, timeout=300)
        except Exception as err:
            print(f"the run under fire: {type(err).__name__}: {err}")
        # The swarm still answers, and a new run gives the engine's answers.
        result = swarm.discover(POLICY, timeout=300)
        assert_matches_engine(
            swarm.world,
            by_pair(result.outcome.estimates),
            evaluate_pairs(swarm.world.hood, POLICY),
        )


def test_generated_world_and_move_messages_stop_nothing(domain, tmp_path):
    """The world's own topics: a revision or a batch of moves is taken whole or not at all."""
    spec = WorldSpec("torus:60", beta=0.5)
    with RunningSwarm.start(SwarmConfig(spec, domain_id=domain, authenticate=False)) as swarm:
        host = swarm.host
        world_node = next(node for node in host.nodes if node.get_name() == "world")
        ids = fls_ids(swarm.world)
        taken = []

        @settings(FUZZ, max_examples=300)
        @given(
            state=message(WorldState, ids),
            moves=message(MoveCommands, ids),
        )
        def throw(state, moves):
            before = host.replica.world.revision
            host.guard.call(WORLD_TOPIC, host._on_world, state)
            world_node.guard.call(MOVE_TOPIC, world_node._on_moves, moves)
            points = host.replica.world.swarm.points
            assert np.isfinite(points).all() and np.abs(points).max() <= 1e6
            taken.append(host.replica.world.revision != before)
            assert host.guard.dropped[(WORLD_TOPIC, INTERNAL)] == 0, host.guard.dropped
            assert world_node.guard.dropped[(MOVE_TOPIC, INTERNAL)] == 0, world_node.guard.dropped

        throw()
        print(f"\n{len(taken)} world and move pairs: {sum(taken)} moved the replica")
        assert world_node.guard.total_dropped > 100
