"""The protocol's numbers are the messages' constants: one code per thing on the wire."""

from __future__ import annotations

import pytest

pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy wheels) is not installed")

from swazure_interfaces.msg import (
    DiscoveryControl,
    MoveCommand,
    PathWalk,
    TrackRequest,
    TrackSample,
)
from swazure_interfaces.srv import ComputePose

from swazure_ros.core import estimators
from swazure_ros.core import relay as core_relay
from swazure_ros.core.paths import POLICIES
from swazure_ros.protocol import moves
from swazure_ros.protocol import tracking as relay
from swazure_ros.protocol.discovery import messages as discovery
from swazure_ros.ros.plumbing import names


@pytest.mark.parametrize(
    ("ours", "theirs"),
    [
        (discovery.SWEET_VISIBLE, DiscoveryControl.PHASE_SWEET_VISIBLE),
        (discovery.SWEET_ALL, DiscoveryControl.PHASE_SWEET_ALL),
        (discovery.ANY_VISIBLE, DiscoveryControl.PHASE_ANY_VISIBLE),
        (discovery.START, DiscoveryControl.COMMAND_START),
        (discovery.ROUND, DiscoveryControl.COMMAND_ROUND),
        (discovery.END, DiscoveryControl.COMMAND_END),
        (moves.STEP_ASIDE, MoveCommand.KIND_STEP_ASIDE),
        (moves.PROBE, MoveCommand.KIND_PROBE),
        (moves.RETURN, MoveCommand.KIND_RETURN),
        (moves.WALKING, PathWalk.STATE_WALKING),
        (moves.ARRIVED, PathWalk.STATE_ARRIVED),
        (moves.FAILED, PathWalk.STATE_FAILED),
        (relay.START_RELAY, TrackRequest.COMMAND_START),
        (relay.STOP_RELAY, TrackRequest.COMMAND_STOP),
        (core_relay.RELAY_OK, TrackSample.STATUS_OK),
        (core_relay.RELAY_TARGET_LOST, TrackSample.STATUS_TARGET_LOST),
        (core_relay.RELAY_SOURCE_LOST, TrackSample.STATUS_SOURCE_LOST),
    ],
)
def test_protocol_codes_equal_the_message_constants(ours, theirs):
    assert ours == theirs


def test_every_name_table_maps_both_ways():
    for codes, names_ in (
        (names.POLICY_CODES, names.POLICY_NAMES),
        (names.TRACK_MODEL_CODES, names.TRACK_MODEL_NAMES),
        (names.TRACK_STATE_CODES, names.TRACK_STATE_NAMES),
    ):
        assert {code: name for name, code in codes.items()} == names_
    assert set(names.TRACK_MODEL_NAMES.values()) == set(estimators.MODELS)
    assert set(names.POLICY_NAMES.values()) == set(POLICIES)  # every policy goes on the wire


def test_compute_pose_and_discovery_share_the_policy_codes():
    for name, code in names.POLICY_CODES.items():
        constant = "POLICY_" + name.upper().replace("-", "_")
        request = ComputePose.Request
        assert getattr(request, constant) == getattr(DiscoveryControl, constant) == code
