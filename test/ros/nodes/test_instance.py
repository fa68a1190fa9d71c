"""The swarm instance's announcement: taken only fresh and signed under the swarm's key."""

from __future__ import annotations

import time

import pytest
from rclpy.serialization import deserialize_message, serialize_message
from swazure_interfaces.msg import SwarmInstance

from swazure_ros.core.errors import MessageError
from swazure_ros.ros.nodes.instance import ANNOUNCEMENT_FRESH, announced, announcement
from swazure_ros.ros.security.auth import SwarmKey, new_key


def wire(message: SwarmInstance) -> SwarmInstance:
    return deserialize_message(serialize_message(message), SwarmInstance)


def test_a_fresh_announcement_under_the_key_gives_the_instance():
    key = SwarmKey(new_key())
    follower = SwarmKey(key.material[0], bytes(16))  # knows the key, not yet the instance
    assert announced(wire(announcement(key)), follower, time.time_ns()) == key.instance


def test_an_announcement_recorded_earlier_or_signed_otherwise_is_refused():
    key = SwarmKey(new_key())
    recorded = wire(announcement(key))
    later = time.time_ns() + int((ANNOUNCEMENT_FRESH + 5) * 1e9)
    with pytest.raises(MessageError, match="a replay or a stale clock"):
        announced(recorded, key, later)
    with pytest.raises(MessageError, match="not signed"):
        announced(wire(announcement(SwarmKey(new_key()))), key, time.time_ns())
    forged = wire(announcement(key))
    forged.instance = bytes(16)  # another instance under a good tag: the tag breaks
    with pytest.raises(MessageError, match="not signed"):
        announced(forged, key, time.time_ns())
