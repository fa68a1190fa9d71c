"""Seeing a running swarm: RViz markers on /swarm/scene and the same scene live in Foxglove."""

from __future__ import annotations

import base64
import json
import struct
import time

import numpy as np
from geometry_msgs.msg import Vector3
from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from swazure_interfaces.msg import MoveCommand, MoveCommands
from visualization_msgs.msg import Marker, MarkerArray
from websockets.sync.client import connect

from swazure_ros.app.config import SwarmConfig, ViewConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.frames import METRES_PER_CM
from swazure_ros.ros.plumbing.names import MOVE_QOS, SCENE_QOS
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.sim.world import WorldSpec
from swazure_ros.view.scene import MOVE_COLOUR

from ...waits import PATIENCE, wait_until

WORLD = WorldSpec("helix:60", beta=0.5)
#: The Foxglove SDK's WebSocket subprotocol; binary frames of op 1 carry message data.
SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 1


def protobuf_class(channel):
    """The message class of an advertised protobuf channel, from its schema alone."""
    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def foxglove_scene(port, topic, timeout=PATIENCE):
    """Connect as Foxglove does, subscribe to ``topic`` and decode the first scene sent."""
    with connect(
        f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], open_timeout=PATIENCE
    ) as ws:
        deadline = time.monotonic() + timeout
        channel = None
        while channel is None:
            message = json.loads(ws.recv(timeout=deadline - time.monotonic()))
            if message["op"] == "advertise":
                channel = next((c for c in message["channels"] if c["topic"] == topic), None)
        ws.send(
            json.dumps(
                {"op": "subscribe", "subscriptions": [{"id": 7, "channelId": channel["id"]}]}
            )
        )
        while True:
            frame = ws.recv(timeout=deadline - time.monotonic())
            if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
                subscription = struct.unpack_from("<I", frame, 1)[0]
                assert subscription == 7
                return channel, protobuf_class(channel).FromString(frame[1 + 4 + 8 :])


def test_a_viewed_swarm_shows_its_flss_in_rviz_and_foxglove_and_follows_a_move(domain):
    config = SwarmConfig(WORLD, domain_id=domain, view=ViewConfig(port=0, seen_from=5))
    received = []
    with RunningSwarm.start(config) as swarm:
        probe = SwarmNode("probe", context=swarm.context)
        probe.create_subscription(MarkerArray, "/swarm/scene", received.append, SCENE_QOS)
        swarm.host.add(probe)
        world, scene = swarm.world, swarm.view.scene

        def until(condition, seconds=30.0):
            return wait_until(condition, seconds, lambda: swarm.spin(0.05))

        # RViz: the latched scene, one sphere per FLS where the world has it, in metres.
        assert until(lambda: len(received) > 0)
        markers = received[-1].markers
        assert markers[0].action == Marker.DELETEALL
        flss = next(m for m in markers if m.ns == "flss")
        assert flss.type == Marker.SPHERE_LIST and len(flss.points) == len(world.ids)
        points = np.array([[p.x, p.y, p.z] for p in flss.points])
        np.testing.assert_allclose(points, world.swarm.points * METRES_PER_CM)
        colours = np.array([[c.r, c.g, c.b, c.a] for c in flss.colors])
        np.testing.assert_allclose(colours, scene.colours, rtol=1e-6)
        assert flss.scale.x == 2 * world.swarm.radius * METRES_PER_CM
        assert scene.highlight == 5  # range classes seen from FLS 5 (helix ids are indices)

        # Foxglove: a viewer that connects now gets the same scene at once.
        channel, update = foxglove_scene(swarm.view.live.port, "/swarm/scene")
        assert channel["schemaName"] == "foxglove.SceneUpdate"
        entities = {entity.id: entity for entity in update.entities}
        spheres = entities["flss"].spheres
        assert len(spheres) == len(world.ids)
        got = np.array(
            [[s.pose.position.x, s.pose.position.y, s.pose.position.z] for s in spheres]
        )
        np.testing.assert_allclose(got, world.swarm.points * METRES_PER_CM)
        got = np.array([[s.color.r, s.color.g, s.color.b, s.color.a] for s in spheres])
        np.testing.assert_allclose(got, scene.colours)

        # A move: the FLS is drawn where the world put it, with an arrow from home.
        moved, shift = 11, np.array([0.0, 0.0, 0.4])
        publisher = probe.create_publisher(MoveCommands, "/swarm/move_commands", MOVE_QOS)
        assert until(lambda: publisher.get_subscription_count() > 0)
        command = MoveCommand(fls_id=moved, kind=MoveCommand.KIND_STEP_ASIDE)
        command.displacement = Vector3(x=shift[0], y=shift[1], z=shift[2])
        # The swarm takes only what its key signs (docs/security.md).
        publisher.publish(swarm.key.serialize(MoveCommands(commands=[command])))

        def arrow_drawn():
            arrows = [m for m in received[-1].markers if m.ns == "moves"]
            return len(arrows) == 1 and arrows

        assert until(arrow_drawn)
        arrow = arrow_drawn()[0]
        home = world.swarm.points[moved]
        start = [arrow.points[0].x, arrow.points[0].y, arrow.points[0].z]
        end = [arrow.points[1].x, arrow.points[1].y, arrow.points[1].z]
        np.testing.assert_allclose(start, home * METRES_PER_CM)
        np.testing.assert_allclose(end, (home + shift) * METRES_PER_CM)
        colour = [arrow.color.r, arrow.color.g, arrow.color.b, arrow.color.a]
        np.testing.assert_allclose(colour, MOVE_COLOUR, rtol=1e-6)  # float32 in the message
        _, update = foxglove_scene(swarm.view.live.port, "/swarm/scene")
        arrows = {entity.id: entity for entity in update.entities}["moves"].arrows
        assert len(arrows) == 1
        np.testing.assert_allclose(
            [arrows[0].pose.position.x, arrows[0].pose.position.y, arrows[0].pose.position.z],
            home * METRES_PER_CM,
        )
