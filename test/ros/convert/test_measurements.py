"""Measurements as bytes: what rclpy's message would be, exactly, and read back as readings."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3
from rclpy.serialization import deserialize_message
from std_msgs.msg import Header
from swazure_interfaces.msg import Measurements, RelativePose

from swazure_ros.core.errors import MessageError
from swazure_ros.core.observe import Measurement
from swazure_ros.core.sensor import DECAYING, SWEET
from swazure_ros.ros.convert.measurements import (
    measurements_bytes,
    read_measurements,
    readings_of,
)
from swazure_ros.ros.security.auth import SwarmKey, content
from swazure_ros.ros.security.keys import new_key

SWARM = np.array([3, 5, 9], dtype=np.int64)
TWO = Measurement(
    np.array([9, 5]),
    np.array([SWEET, DECAYING], dtype=np.int8),
    np.array([[7.3, -6.1, 0.25], [1.0, 2.0, 3.0]]),
    np.array([6.5, 9.0]),
)


def by_hand(fls_id, measurement, stamp, radio):
    """The message as rclpy objects, field by field, in metres (the reference)."""
    message = Measurements(source_id=fls_id)
    message.header.stamp = stamp
    message.header.frame_id = f"fls_{fls_id}"
    for k, target in enumerate(measurement.target_ids.tolist()):
        x, y, z = (measurement.vector[k] / 100).tolist()
        pose = RelativePose(
            source_id=fls_id,
            target_id=target,
            range_class=int(measurement.range_class[k]),
            line_of_sight=True,
            vector=Vector3(x=x, y=y, z=z),
            tracking_distance=float(measurement.tracking[k] / 100),
            radio_distance=float(radio[k] / 100),
        )
        pose.header = message.header
        message.poses.append(pose)
    return message


def twins(active):
    """Two keys that sign alike: the same key, instance, sender and counter."""
    first = SwarmKey(new_key() if active else None)
    second = first.for_instance(first.instance)
    second.sender = first.sender
    first._counter = second._counter = 2**62  # the next counter: the same for both
    return first, second


@pytest.mark.parametrize("active", [False, True], ids=["keyless", "signed"])
@pytest.mark.parametrize("fls_id", [0, 7, 12, 345, 65535])
@pytest.mark.parametrize("count", [0, 1, 2, 5, 300])
def test_the_bytes_are_the_serialised_signed_message(active, fls_id, count):
    # Frame names of 5 to 9 characters move the first pose to either alignment.
    rng = np.random.default_rng(count * 70_000 + fls_id)
    measurement = Measurement(
        np.sort(rng.choice(70_000, count, replace=False)).astype(np.int64),
        rng.choice([SWEET, DECAYING], count).astype(np.int8),
        rng.normal(size=(count, 3)) * 10,
        rng.random(count) * 30,
    )
    radio = rng.random(count) * 40
    stamp = Time(sec=int(rng.integers(0, 2**31 - 1)), nanosec=int(rng.integers(0, 10**9)))
    ours, reference = twins(active)
    sent = measurements_bytes(fls_id, measurement, stamp, ours, radio)
    message = by_hand(fls_id, measurement, stamp, radio)
    assert sent == reference.serialize(message)
    # Read back: every field, and what the tag covers, as rclpy reads them.
    got = read_measurements(sent)
    assert got.content == content(deserialize_message(sent, Measurements))
    assert (got.source_id, got.stamp) == (fls_id, (stamp.sec, stamp.nanosec))
    np.testing.assert_array_equal(got.target_ids, measurement.target_ids)
    np.testing.assert_array_equal(got.pose_source_ids, np.full(count, fls_id))
    np.testing.assert_array_equal(got.range_class, measurement.range_class)
    np.testing.assert_allclose(got.vector, measurement.vector, rtol=1e-15, atol=1e-13)
    np.testing.assert_allclose(got.radio_distance, radio, rtol=1e-15, atol=1e-13)
    assert got.line_of_sight.all()
    if active:
        reference.verify_content(got.auth, got.content)


def test_measurements_read_back_as_the_readings_a_fit_takes():
    sent = measurements_bytes(3, TWO, Time(sec=1), SwarmKey(), np.array([6.4, 9.1]))
    readings = readings_of(read_measurements(sent), SWARM)
    # Sorted by the measured FLS, in cm, as the engine lays a window's readings out.
    np.testing.assert_array_equal(readings.other, [5, 9])
    np.testing.assert_array_equal(readings.range_class, [DECAYING, SWEET])
    np.testing.assert_allclose(readings.vector, [[1.0, 2.0, 3.0], [7.3, -6.1, 0.25]], rtol=1e-15)
    np.testing.assert_allclose(readings.distance, [9.1, 6.4], rtol=1e-15)


def wire(message):
    return SwarmKey().serialize(message)


@pytest.mark.parametrize(
    ("spoil", "reason"),
    [
        (lambda m: setattr(m.poses[0], "range_class", RelativePose.RANGE_BLIND), "camera range"),
        (lambda m: setattr(m.poses[1], "source_id", 5), "a pose of another FLS"),
        (lambda m: setattr(m.poses[1], "target_id", 9), "measured twice"),
        (lambda m: setattr(m.poses[1], "target_id", 3), "measures itself"),
        (lambda m: setattr(m.poses[1], "target_id", 4), "poses"),
        (lambda m: setattr(m.poses[0].vector, "x", float("inf")), "poses"),
    ],
    ids=["blind", "another-source", "twice", "itself", "stranger", "infinite"],
)
def test_readings_of_a_false_message_are_refused(spoil, reason):
    message = by_hand(3, TWO, Time(sec=1), np.array([6.4, 9.1]))
    spoil(message)
    with pytest.raises(MessageError, match=reason):
        readings_of(read_measurements(wire(message)), SWARM)


def test_bytes_that_are_not_an_fls_s_measurements_are_refused():
    message = by_hand(3, TWO, Time(sec=1), np.array([6.4, 9.1]))
    sent = wire(message)
    with pytest.raises(MessageError, match="end inside"):
        read_measurements(sent[:-40])
    with pytest.raises(MessageError, match="little-endian"):
        read_measurements(b"\x00\x00" + sent[2:])
    # A pose in another frame: not how an FLS sends them.
    message.poses[1].header = Header(stamp=message.header.stamp, frame_id="fls_4")
    with pytest.raises(MessageError, match="header is not its message's"):
        read_measurements(wire(message))


def test_a_tag_over_other_content_is_refused():
    signer, checker = twins(active=True)
    sent = read_measurements(measurements_bytes(3, TWO, Time(sec=1), signer, np.ones(2)))
    checker.verify_content(sent.auth, sent.content)
    other = read_measurements(measurements_bytes(3, TWO, Time(sec=2), SwarmKey(), np.ones(2)))
    with pytest.raises(MessageError, match="not signed"):
        checker.verify_content(sent.auth, other.content)
