"""The guard's limits: a sender's rate of work-causing messages, and replays across instances."""

from __future__ import annotations

import secrets
import time

from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from swazure_interfaces.msg import PathOffer, TrackRequest

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.errors import MessageError
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.ros.nodes.radio import TRACK_REQUEST_RATE
from swazure_ros.ros.plumbing.names import ROUND_QOS, TRACK_REQUESTS_TOPIC
from swazure_ros.ros.security.auth import AUTH_BYTES, Freshness, SwarmKey, new_key
from swazure_ros.ros.security.guard import Buckets, RateLimit
from swazure_ros.sim.world import WorldSpec

from ...conftest import FUZZ
from ...waits import wait_until
from ..conftest import make_context
from ..test_discovery import assert_matches_engine, by_pair


def signed(key: SwarmKey) -> PathOffer:
    return deserialize_message(key.serialize(PathOffer(run_id=1)), PathOffer)


def test_a_sender_gets_its_burst_then_its_rate_and_senders_have_buckets_of_their_own():
    buckets = Buckets(RateLimit(per_second=2.0, burst=3.0), keyed=True)
    first, second = signed(SwarmKey(new_key())), signed(SwarmKey(new_key()))
    assert [buckets.allow(first, 0.0) for _ in range(4)] == [True, True, True, False]
    assert buckets.allow(second, 0.0)  # another sender: its own bucket
    assert not buckets.allow(first, 0.4)  # 0.8 tokens back
    assert buckets.allow(first, 0.6) and not buckets.allow(first, 0.6)
    assert [buckets.allow(first, 100.0) for _ in range(4)] == [True, True, True, False]
    # Unsigned senders cannot be told apart: they share one bucket.
    unsigned = Buckets(RateLimit(per_second=1.0, burst=1.0), keyed=True)
    assert unsigned.allow(PathOffer(), 0.0) and not unsigned.allow(PathOffer(), 0.0)


def test_without_a_key_made_up_sender_ids_share_one_bucket():
    # Without a key, auth is whatever a peer wrote there: 48 bytes of it name no sender.
    buckets = Buckets(RateLimit(per_second=1.0, burst=2.0), keyed=False)
    made_up = [PathOffer(auth=list(secrets.token_bytes(AUTH_BYTES))) for _ in range(3)]
    assert [buckets.allow(message, 0.0) for message in made_up] == [True, True, False]
    assert not buckets.allow(signed(SwarmKey(new_key())), 0.5)  # a real tag: no key to check it
    assert buckets.allow(PathOffer(), 1.5)


@settings(FUZZ, max_examples=100)
@given(data=st.data())
def test_replayed_and_reordered_messages_of_two_instances_are_each_taken_once_if_ours(data):
    """Messages of two swarm instances of one key, from three senders, duplicated and
    shuffled: a receiver of instance A takes each of A's exactly once, none of B's."""
    secret = new_key()
    ours = SwarmKey(secret)
    senders = [ours.for_instance(ours.instance), ours.for_instance(ours.instance)]
    theirs = SwarmKey(secret)  # the earlier swarm, its recording replayed
    made = [
        (owner, data.draw(st.integers(0, 2**31 - 1)))
        for owner in data.draw(st.lists(st.sampled_from([0, 1, 2]), min_size=1, max_size=30))
    ]
    keys = [*senders, theirs]
    wire = [(owner, keys[owner].serialize(PathOffer(run_id=run_id))) for owner, run_id in made]
    played = data.draw(st.lists(st.sampled_from(range(len(wire))), max_size=80))
    order = data.draw(st.permutations([*range(len(wire)), *played]))
    receiver, freshness = ours.for_instance(ours.instance), Freshness()
    taken: list[int] = []
    for index in order:
        try:
            freshness.take(receiver.deserialize(wire[index][1], PathOffer))
        except MessageError as refused:
            assert (wire[index][0] == 2) == ("instance" in refused.reason), refused.reason
            continue
        taken.append(index)
    assert sorted(taken) == [i for i, (owner, _) in enumerate(wire) if owner != 2]


def test_a_flood_of_track_requests_is_cut_to_the_rate_and_the_swarm_still_answers(domain):
    world_spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    # No key: every request is taken by the key check, so the rate limit is what stops them.
    config = SwarmConfig(world_spec, domain_id=domain, authenticate=False)
    with RunningSwarm(config) as swarm:
        swarm.wait_until_ready()
        context = make_context(domain)
        node = Node("flooder", namespace="swarm", context=context)
        try:
            requests = node.create_publisher(TrackRequest, TRACK_REQUESTS_TOPIC, ROUND_QOS)
            wait_until(
                lambda: requests.get_subscription_count() >= 1, 30, lambda: swarm.spin(0.05)
            )
            relay = int(swarm.world.ids[1])
            began = time.monotonic()
            for _ in range(1000):
                requests.publish(
                    TrackRequest(source_id=int(swarm.world.ids[0]), target_id=relay,
                                 relay_id=relay, frame_period=0.001)
                )  # fmt: skip
            limited = "over # a second from all senders, unsigned (rate limit)"
            reason = (TRACK_REQUESTS_TOPIC, limited)
            wait_until(
                lambda: (
                    swarm.host.guard.dropped[reason]
                    + swarm.host.guard.accepted[TRACK_REQUESTS_TOPIC]
                    >= 1000
                ),
                30,
                lambda: swarm.spin(0.05),
            )
            seconds = time.monotonic() - began
        finally:
            node.destroy_node()
            context.try_shutdown()
        taken = swarm.host.guard.accepted[TRACK_REQUESTS_TOPIC]
        allowed = TRACK_REQUEST_RATE.burst + TRACK_REQUEST_RATE.per_second * seconds
        assert taken <= allowed, (taken, seconds)
        assert swarm.host.guard.dropped[reason] >= 1000 - allowed
        result = swarm.discover("shortest-length", timeout=120)
        engine = evaluate_pairs(swarm.world.hood, "shortest-length")
        assert_matches_engine(swarm.world, by_pair(result.outcome.estimates), engine)
