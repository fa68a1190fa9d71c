"""The guard's limits: a sender's rate of work-causing messages, and replays across instances."""

from __future__ import annotations

import secrets
import time

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from swazure_interfaces.msg import PathOffer, TrackRequest

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.errors import MessageError
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.protocol.tracking import RELAYED_STREAMS
from swazure_ros.ros.convert.discovery import pose_estimate_from_message
from swazure_ros.ros.nodes.radio import TRACK_REQUEST_RATE
from swazure_ros.ros.plumbing.names import ROUND_QOS, TRACK_REQUESTS_TOPIC
from swazure_ros.ros.security.auth import AUTH_BYTES, Freshness, SwarmKey, new_key
from swazure_ros.ros.security.guard import Buckets, RateLimit
from swazure_ros.sim.world import WorldSpec

from ...conftest import FUZZ
from ...waits import PATIENCE, wait_until
from ..test_discovery import Client, assert_matches_engine, by_pair

#: Track requests a flood sends.
FLOOD = 2000


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


def plausible_relays(swarm, count):
    """``count`` (source, relay, target) of streams a relay would take: the source's choice."""
    ids = swarm.world.ids.tolist()
    senses = swarm.host.replica.relay_senses
    found = []
    for source in ids:
        for target in ids:
            relay = senses.choose_relay(source, target, 0.0) if source != target else None
            if relay is not None:
                found.append((source, relay, target))
                if len(found) == count:
                    return found
    return found


def test_a_flood_of_track_requests_with_made_up_auths_leaves_compute_pose_answering(
    domain, context
):
    """No key; each request of a flood carries a made-up 48-byte auth, a plausible relay, and
    a first frame of now.

    Before, each made-up sender id had a bucket of its own, and every stream a relay took
    lasted for good: on this torus, 220 streams turned a 0.1 s compute_pose into 23 s, then
    into no answer within 120 s."""
    world_spec = WorldSpec("torus:120", scale=1.6, beta=0.5)
    config = SwarmConfig(world_spec, domain_id=domain, authenticate=False)
    with RunningSwarm.start(config) as swarm:
        node = Node("flooder", namespace="swarm", context=context)
        requests = node.create_publisher(TrackRequest, TRACK_REQUESTS_TOPIC, ROUND_QOS)
        wait_until(
            lambda: requests.get_subscription_count() >= 1, PATIENCE, lambda: swarm.spin(0.05)
        )
        streams = plausible_relays(swarm, 100)
        guard = swarm.host.guard

        def heard() -> int:
            """Requests taken or dropped (a stream stopped for a new one is no request)."""
            dropped = sum(
                count
                for (topic, why), count in guard.dropped.items()
                if topic == TRACK_REQUESTS_TOPIC and "streams relayed" not in why
            )
            return guard.accepted[TRACK_REQUESTS_TOPIC] + dropped

        began = time.monotonic()
        for index in range(FLOOD):
            if index % 100 == 0:
                swarm.spin(0.05)  # so that the first frames stay within a timeout of now
            source, relay, target = streams[index % len(streams)]
            request = TrackRequest(source_id=source, relay_id=relay, target_id=target,
                                   auth=list(secrets.token_bytes(AUTH_BYTES)))  # fmt: skip
            request.header.stamp = node.get_clock().now().to_msg()
            requests.publish(request)
        wait_until(lambda: heard() >= FLOOD, PATIENCE, lambda: swarm.spin(0.05))
        seconds = time.monotonic() - began
        node.destroy_node()
        taken = guard.accepted[TRACK_REQUESTS_TOPIC]
        allowed = TRACK_REQUEST_RATE.burst + TRACK_REQUEST_RATE.per_second * seconds
        assert heard() >= FLOOD and taken <= allowed, (guard.accepted, guard.dropped, seconds)
        limited = (TRACK_REQUESTS_TOPIC, "over # a second from all senders, unsigned (rate limit)")
        assert guard.dropped[limited] >= FLOOD - allowed, guard.dropped
        relayed = sum(len(fls.tracking.relay) for fls in swarm.host.fls_nodes)
        assert 0 < relayed <= RELAYED_STREAMS < len(streams)
        # compute_pose answers, as the engine does, while what the flood left runs.
        engine = evaluate_pairs(swarm.world.hood, "fewest-hops")
        pair = int(np.flatnonzero(engine.hops >= 2)[0])
        source, target = (
            int(swarm.world.ids[engine.source[pair]]),
            int(swarm.world.ids[engine.target[pair]]),
        )
        client = Client(swarm, context)
        try:
            response = client.call(source, target)
        finally:
            client.close()
        assert response.success, response.message
        estimate = pose_estimate_from_message(response.estimate)
        assert estimate.path == tuple(int(swarm.world.ids[k]) for k in engine.path(pair))
        result = swarm.discover("shortest-length", timeout=PATIENCE)
        engine = evaluate_pairs(swarm.world.hood, "shortest-length")
        assert_matches_engine(swarm.world, by_pair(result.outcome.estimates), engine)


def test_the_guard_counts_the_bytes_its_subscriptions_hear_less_echoes_and_reports_them(context):
    """Each message a guarded subscription takes in adds its bytes, taken or dropped; the
    process's own echo adds none; /diagnostics says the sum."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor

    from swazure_ros.ros.security.guard import Guard

    node = Node("guarded", context=context)
    key = SwarmKey(new_key())
    guard = Guard(node, key)
    taken: list[int] = []
    wire = [key.serialize(PathOffer(run_id=run_id)) for run_id in (1, 22, 333)]
    forged = SwarmKey(new_key()).serialize(PathOffer(run_id=4))  # heard, then dropped
    echo = key.serialize(PathOffer(run_id=5))  # this process's own, come back
    guard.subscribe(
        PathOffer, "offers", lambda m: taken.append(m.run_id), ROUND_QOS, echoes=echo.__eq__
    )
    reports: list[dict[str, str]] = []
    node.create_subscription(
        DiagnosticArray,
        "/diagnostics",
        lambda array: reports.extend({v.key: v.value for v in s.values} for s in array.status),
        10,
    )
    publisher = node.create_publisher(PathOffer, "offers", ROUND_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    assert wait_until(lambda: publisher.get_subscription_count() > 0, step=spin)
    # The echo first: one writer's messages arrive in order, so it was heard by the end.
    for data in [echo, *wire, forged]:
        publisher.publish(data)
    expected = sum(len(data) for data in [*wire, forged])
    assert wait_until(
        lambda: guard.heard_bytes["offers"] == expected and len(taken) == 3, step=spin
    )
    assert taken == [1, 22, 333] and guard.total_dropped == 1
    guard.publish()
    assert wait_until(lambda: any("heard bytes offers" in r for r in reports), step=spin)
    assert [r["heard bytes offers"] for r in reports if "heard bytes offers" in r][-1] == str(
        expected
    )
    executor.shutdown()
    node.destroy_node()
