"""FLS nodes with the rendering camera over real DDS: measurements, and what an FLS sees."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image

from swazure_ros.files.reading import config_dir
from swazure_ros.ros.nodes.fls_node import FlsNode, ParameterError
from swazure_ros.ros.programs.host import HostConfig, SwarmHost
from swazure_ros.sim.world import WorldSpec

from ...waits import PATIENCE
from ..conftest import make_context
from ..helpers import assert_matches, engine_expectations, spin_until
from .test_fls_nodes import collect_measurements

CAMERA_SENSOR = str(config_dir() / "cameras" / "sensor-wide-camera.yaml")
# Stretched so that neighbours sit in the camera's ranges (5 to 24 cm).
WORLD = WorldSpec("helix:30", scale=3.0, beta=0.5, sensor_file=CAMERA_SENSOR)
FAST = ["--ros-args", "-p", "publish_period:=0.2"]


def hosted(domain, fls_ids=None, parameters=None):
    ctx = make_context(domain, FAST)
    world = WORLD.build()
    ids = tuple(world.ids if fls_ids is None else fls_ids)
    host = SwarmHost(world, HostConfig(ids, parameters=parameters or {}), context=ctx)
    probe = Node("probe", context=ctx, start_parameter_services=False, enable_rosout=False)
    host.executor.add_node(probe)
    return ctx, world, host, probe


def close(ctx, host, probe):
    host.executor.remove_node(probe)
    probe.destroy_node()
    host.close()
    ctx.try_shutdown()


def test_nodes_measuring_with_the_rendering_camera_publish_the_engines_vectors(domain):
    ctx, world, host, probe = hosted(domain)
    try:
        host.create_fls_nodes()
        assert host.spin_until_discovered(60)
        expected, _ = engine_expectations(world)
        assert sum(map(len, expected.values())) >= 40  # rendered, detected and solved pairs
        latest = collect_measurements(host, probe, expected)
        for fls_id, message in latest.items():
            assert_matches(message, expected[fls_id])
        # Rendered, not the model: no vector is the true one stretched along its direction.
        truth = world.swarm.points
        some = next(fls for fls in expected if expected[fls])
        target, vector = next(iter(expected[some].items()))
        true = truth[world.index(target)] - truth[world.index(some)]
        assert (
            np.degrees(np.arccos(vector @ true / np.linalg.norm(vector) / np.linalg.norm(true)))
            > 1e-6
        )
    finally:
        close(ctx, host, probe)


def test_an_fls_shows_what_its_camera_sees_aimed_at_a_neighbour(domain):
    world = WORLD.build()
    measured = world.measurement(int(world.ids[0]))
    neighbour = int(measured.target_ids[0])
    ctx, world, host, probe = hosted(domain, [int(world.ids[0])], {"camera_view": neighbour})
    try:
        host.create_fls_nodes()
        images, infos = [], []
        probe.create_subscription(Image, "/swarm/fls_0/camera/image_raw", images.append, 1)
        probe.create_subscription(CameraInfo, "/swarm/fls_0/camera/camera_info", infos.append, 1)
        assert spin_until(host.executor, lambda: images and infos, timeout=PATIENCE)
        image, info = images[-1], infos[-1]
        assert (image.width, image.height, image.encoding, image.step) == (
            1280,
            720,
            "mono8",
            1280,
        )
        assert image.header.frame_id == "fls_0_camera_optical" == info.header.frame_id
        assert info.k[0] == pytest.approx(836.8) and (info.width, info.height) == (1280, 720)
        pixels = np.frombuffer(bytes(image.data), np.uint8).reshape(720, 1280)
        detector = cv2.aruco.ArucoDetector(
            cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_100)
        )
        corners, ids, _ = detector.detectMarkers(pixels)
        # The neighbour's own marker: FLS k carries marker k mod 100 (markers: all).
        assert ids is not None and ids.ravel().tolist() == [world.index(neighbour) % 100]
        # The marker's side in pixels says how far it is: fx * 4.7 mm / distance.
        side = np.linalg.norm(corners[0][0, 1] - corners[0][0, 0])
        offset = world.position(neighbour) - world.position(0)
        distance_mm = 10 * (np.linalg.norm(offset) - 2 * world.swarm.radius)
        assert side == pytest.approx(836.8 * 4.7 / distance_mm, rel=0.1)
    finally:
        close(ctx, host, probe)


@pytest.mark.parametrize("view", [0, 999])
def test_camera_view_of_itself_or_of_a_stranger_is_a_parameter_error(domain, view):
    from rclpy.parameter import Parameter

    from swazure_ros.sim.replica import WorldReplica

    ctx = make_context(domain)
    try:
        with pytest.raises(ParameterError, match="camera_view"):
            FlsNode(
                0,
                WorldReplica(WORLD.build()),
                context=ctx,
                parameter_overrides=[Parameter("camera_view", value=view)],
            )
    finally:
        ctx.try_shutdown()
