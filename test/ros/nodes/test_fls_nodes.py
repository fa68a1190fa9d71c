"""FLS nodes in one process over real DDS: measurements and neighbour sets equal the engine's."""

from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import Vector3
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from swazure_interfaces.msg import Measurements, MoveCommand, MoveCommands, RelativePose
from swazure_interfaces.srv import GetNeighbours
from tf2_msgs.msg import TFMessage

from swazure_ros.ros.nodes.fls_node import FlsNode, ParameterError
from swazure_ros.ros.plumbing.names import TF_STATIC_QOS
from swazure_ros.ros.programs.host import HostConfig, SwarmHost
from swazure_ros.sim.replica import WorldReplica
from swazure_ros.sim.world import WorldSpec

from ...waits import PATIENCE
from ..conftest import make_context
from ..helpers import (
    LATCHED,
    assert_matches,
    engine_expectations,
    matches,
    spin_until,
)

WORLD = WorldSpec("helix:100", beta=0.5)
TRACK_SERVICE_ON = Parameter("track.service", value=True)
FAST = ["--ros-args", "-p", "publish_period:=0.2"]


@pytest.fixture
def swarm(domain):
    """A 100-FLS helix, every FLS its own node, and a probe node, in one process."""
    ctx = make_context(domain, FAST)
    world = WORLD.build()
    host = SwarmHost(world, HostConfig(tuple(world.ids)), context=ctx)
    probe = Node("probe", context=ctx, start_parameter_services=False, enable_rosout=False)
    host.executor.add_node(probe)
    try:
        host.create_fls_nodes()
        assert host.spin_until_discovered(60)
        yield world, host, probe
    finally:
        host.executor.remove_node(probe)
        probe.destroy_node()
        host.close()
        ctx.try_shutdown()


def collect_measurements(host, probe, expected):
    """Every FLS's newest measurement, once each equals ``expected`` ({id: {id: (3,)}})."""
    latest = {}
    subscription = probe.create_subscription(
        Measurements, "/swarm/measurements", lambda m: latest.__setitem__(m.source_id, m), LATCHED
    )

    def all_expected():
        return len(latest) == len(expected) and all(
            matches(latest[fls_id], vectors) for fls_id, vectors in expected.items()
        )

    spin_until(host.executor, all_expected, timeout=PATIENCE)
    probe.destroy_subscription(subscription)
    return latest


def call(host, probe, fls_id, asked=None):
    client = probe.create_client(GetNeighbours, f"/swarm/fls_{fls_id}/get_neighbours")
    assert spin_until(host.executor, lambda: client.service_is_ready(), timeout=PATIENCE)
    # No id asks the FLS about itself.
    request = GetNeighbours.Request() if asked is None else GetNeighbours.Request(fls_id=asked)
    future = client.call_async(request)
    assert spin_until(host.executor, future.done, timeout=PATIENCE)
    probe.destroy_client(client)
    return future.result()


def test_every_node_publishes_the_engines_measured_vectors(swarm):
    world, host, probe = swarm
    assert len(world.ids) >= 30
    expected, _ = engine_expectations(world)
    assert sum(map(len, expected.values())) > 1000  # a swarm whose FLSs measure each other
    latest = collect_measurements(host, probe, expected)
    assert set(latest) == set(world.ids.tolist())
    for fls_id, message in latest.items():
        assert_matches(message, expected[fls_id])
        assert all(pose.source_id == fls_id and pose.line_of_sight for pose in message.poses)
        assert message.header.frame_id == f"fls_{fls_id}"


def test_neighbour_service_of_each_node_returns_the_engines_sets(swarm):
    world, host, probe = swarm
    _, expected = engine_expectations(world)
    # Sweet neighbours out of sight exist, so radio and camera sets differ.
    assert any(sets["sweet"] - sets["visible_sweet"] for sets in expected.values())
    assert any(sets["decaying"] for sets in expected.values())
    for fls_id in world.ids.tolist():
        response = call(host, probe, fls_id)
        assert response.success, response.message
        sets = expected[fls_id]
        assert list(response.blind_ids) == sorted(sets["blind"])
        assert list(response.sweet_ids) == sorted(sets["sweet"])
        assert list(response.visible_sweet_ids) == sorted(sets["visible_sweet"])
        assert list(response.decaying_ids) == sorted(sets["decaying"])


def test_request_for_a_missing_fls_is_an_error_response_and_the_node_keeps_serving(swarm):
    world, host, probe = swarm
    fls_id = int(world.ids[3])
    response = call(host, probe, fls_id, asked=99_999)
    assert not response.success
    assert "99999" in response.message and str(fls_id) in response.message
    assert list(response.blind_ids) == []
    refused = call(host, probe, fls_id, asked=-7)
    assert not refused.success and "fls_id -7" in refused.message, refused.message
    assert call(host, probe, fls_id).success
    # Its own id, given, is the same question as no id.
    assert call(host, probe, fls_id, asked=fls_id) == call(host, probe, fls_id)


def test_a_move_command_changes_what_the_nodes_measure(swarm):
    world, host, probe = swarm
    mover = int(world.ids[10])
    shift = np.array([0.0, 0.0, 0.4])
    moved_world = world.moved({mover: world.position(mover) + shift})
    expected, _ = engine_expectations(moved_world)
    publisher = probe.create_publisher(MoveCommands, "/swarm/move_commands", 10)
    command = MoveCommand(fls_id=mover, kind=MoveCommand.KIND_STEP_ASIDE)
    command.displacement = Vector3(x=shift[0], y=shift[1], z=shift[2])
    assert spin_until(host.executor, lambda: publisher.get_subscription_count() > 0)
    publisher.publish(MoveCommands(commands=[command]))
    assert spin_until(host.executor, lambda: host.replica.world.revision == 1)
    latest = collect_measurements(host, probe, expected)
    for fls_id, message in latest.items():
        assert_matches(message, expected[fls_id])
    back = MoveCommand(fls_id=mover, kind=MoveCommand.KIND_RETURN)
    publisher.publish(MoveCommands(commands=[back]))
    assert spin_until(host.executor, lambda: host.replica.world.revision == 2)
    np.testing.assert_array_equal(host.replica.world.position(mover), world.position(mover))


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("-1.0", "publish_period must be a positive number"),
        ("fast", "publish_period"),
        ("yes-please", "track.service"),
    ],
)
def test_invalid_parameter_refuses_to_start_with_one_clear_line(domain, value, message):
    name = message.split()[0]
    ctx = make_context(domain, ["--ros-args", "-p", f"{name}:={value}"])
    world = WORLD.build()
    try:
        with pytest.raises(ParameterError, match=message) as raised:
            FlsNode(int(world.ids[0]), world, context=ctx)
        assert "\n" not in str(raised.value)
        assert "/swarm/fls_" in str(raised.value)
    finally:
        ctx.try_shutdown()


def test_an_fls_offers_the_track_service_only_where_its_parameter_asks(context):
    world = WORLD.build()
    replica = WorldReplica(world)
    tracker, plain = int(world.ids[0]), int(world.ids[1])
    nodes = [
        FlsNode(tracker, replica, context=context, parameter_overrides=[TRACK_SERVICE_ON]),
        FlsNode(plain, replica, context=context),
    ]
    nodes[1].offer_neighbours_service()
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    for node in (*nodes, probe):
        executor.add_node(node)

    def services():
        return {name for name, _ in probe.get_service_names_and_types()}

    try:
        want = {f"/swarm/fls_{plain}/get_neighbours", f"/swarm/fls_{tracker}/track"}
        assert spin_until(executor, lambda: want <= services(), timeout=PATIENCE)
        assert f"/swarm/fls_{plain}/track" not in services()
        assert nodes[0].get_parameter("track.service").value is True
        assert nodes[1].get_parameter("track.service").value is False
    finally:
        for node in (*nodes, probe):
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()


def count_measurements(host, probe, seconds):
    """Measurements messages a reader that joins now gets in ``seconds`` (latched ones first)."""
    received = []
    subscription = probe.create_subscription(
        Measurements, "/swarm/measurements", received.append, LATCHED
    )
    host.spin_for(seconds)
    probe.destroy_subscription(subscription)
    return len(received)


def test_an_idle_swarm_sends_a_measurement_once_and_a_late_reader_still_gets_every_one(swarm):
    world, host, probe = swarm
    expected, _ = engine_expectations(world)
    collect_measurements(host, probe, expected)
    # Ten frames of 0.2 s: a reader that joins gets one latched message per FLS, then none.
    assert count_measurements(host, probe, 2.0) == len(world.ids)
    # At rest, nothing to send, no frame taken: the timers wait for a change or a reader.
    frames = sum(node.frames_taken for node in host.fls_nodes)
    host.spin_for(1.0)
    assert sum(node.frames_taken for node in host.fls_nodes) == frames


def test_nodes_build_no_measurement_while_nobody_reads_and_a_reader_gets_the_current_one(swarm):
    world, host, probe = swarm
    host.spin_for(1.0)  # five frames of 0.2 s, nobody subscribed
    assert sum(node.measurements_sent for node in host.fls_nodes) == 0
    expected, _ = engine_expectations(world)
    collect_measurements(host, probe, expected)
    # At rest, one message per FLS: the first frame after the reader came.
    assert sum(node.measurements_sent for node in host.fls_nodes) == len(world.ids)


def test_republish_period_sends_unchanged_measurements_again(domain):
    ctx = make_context(domain, [*FAST, "-p", "republish_period:=0.4"])
    world = WORLD.build()
    with SwarmHost(world, HostConfig(tuple(world.ids)), context=ctx) as host:
        probe = Node("probe", context=ctx, start_parameter_services=False, enable_rosout=False)
        host.add(probe)
        host.create_fls_nodes()
        assert host.spin_until_discovered(60)
        # The latched message, then one at the first frame 0.4 s after each (frames
        # every 0.2 s): two more per FLS within about a second, later on a loaded machine.
        received = []
        probe.create_subscription(Measurements, "/swarm/measurements", received.append, LATCHED)
        wanted = 3 * len(world.ids)
        arrived = spin_until(host.executor, lambda: len(received) >= wanted, timeout=PATIENCE)
        assert arrived, f"{len(received)} of {wanted}"
    ctx.try_shutdown()


def test_tf_places_every_fls_and_a_measurement_lands_on_its_target(swarm):
    world, host, probe = swarm
    frames = {}

    def take(message):
        for one in message.transforms:
            frames[one.child_frame_id] = one

    probe.create_subscription(TFMessage, "/tf_static", take, TF_STATIC_QOS)
    names = {f"fls_{fls_id}" for fls_id in world.ids.tolist()}
    assert spin_until(host.executor, lambda: names <= set(frames), timeout=PATIENCE), len(frames)
    positions = {}
    for fls_id, point in zip(world.ids.tolist(), world.swarm.points, strict=True):
        frame = frames[f"fls_{fls_id}"]
        assert frame.header.frame_id == "swarm"  # the one fixed frame: the display's
        t, r = frame.transform.translation, frame.transform.rotation
        positions[fls_id] = np.array([t.x, t.y, t.z])
        # Metres (REP-103), where the FLS is; its axes are the swarm's.
        assert np.allclose(positions[fls_id], point / 100, rtol=0, atol=1e-12)
        assert (r.x, r.y, r.z, r.w) == (0.0, 0.0, 0.0, 1.0)
    expected, _ = engine_expectations(world)
    placed = 0
    for fls_id, message in collect_measurements(host, probe, expected).items():
        # A measurement's frame exists on /tf_static; placed there, it lands on its target.
        assert message.header.frame_id in frames
        for pose in message.poses:
            if pose.range_class != RelativePose.RANGE_SWEET:
                continue
            v = pose.vector
            landed = positions[fls_id] + np.array([v.x, v.y, v.z])
            truth = positions[pose.target_id] - positions[fls_id]
            # Within the sensor's sweet-range error: a few % of the distance.
            assert np.linalg.norm(landed - positions[pose.target_id]) < 0.05 * np.linalg.norm(
                truth
            )
            placed += 1
    assert placed > 100
