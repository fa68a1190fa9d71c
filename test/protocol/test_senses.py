"""An FLS's own senses (the shape and its camera's detections) against the simulator's."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core.errors import UnknownFlsError
from swazure_ros.protocol.senses import DetectedSenses, carried_markers
from swazure_ros.sim.world import WorldSpec


@pytest.fixture(scope="module")
def world():
    return WorldSpec("torus:120", scale=1.6, beta=0.5).build()


def senses_fed_by_the_simulator(world, fls_id):
    """An FLS's own senses, fed what the simulated camera reads (as the world program does)."""
    senses = DetectedSenses(
        fls_id, world.ids, world.swarm.points, world.sensor, world.swarm.radius
    )
    seen = world.measurement(fls_id)
    markers = carried_markers(world.sensor, world.ids)[world.indices(seen.target_ids)]
    senses.detect(markers, seen.vector)
    return senses


def test_an_fls_knows_what_the_simulator_says_it_senses(world):
    for fls_id in world.ids[:40].tolist():
        own = senses_fed_by_the_simulator(world, fls_id).view(fls_id)
        simulated = world.view(fls_id)
        np.testing.assert_array_equal(own.other, simulated.other)
        np.testing.assert_array_equal(own.range_class, simulated.range_class)
        np.testing.assert_array_equal(own.distance, simulated.distance)  # to the bit
        np.testing.assert_array_equal(own.visible, simulated.visible)
        np.testing.assert_array_equal(own.vector, simulated.vector)
    assert sum(len(world.measurement(i).target_ids) for i in world.ids[:40].tolist()) > 40


def test_a_marker_reads_as_the_nearest_fls_that_carries_it(world):
    # Three markers for the whole swarm: FLS k carries k mod 3, as a small dictionary would.
    from dataclasses import replace

    from swazure_ros.files.reading import config_dir
    from swazure_ros.files.sensors import load_camera

    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    sensor = replace(world.sensor, camera=camera, camera_markers=(0, 1, 2))
    fls_id = int(world.ids[0])
    senses = DetectedSenses(fls_id, world.ids, world.swarm.points, sensor, world.swarm.radius)
    seen = world.measurement(fls_id)
    assert len(seen.target_ids)
    markers = carried_markers(sensor, world.ids)[world.indices(seen.target_ids)]
    senses.detect(markers, seen.vector)
    np.testing.assert_array_equal(senses.measurement(fls_id).target_ids, seen.target_ids)


def test_a_marker_no_neighbour_carries_is_left_out(world):
    fls_id = int(world.ids[0])
    senses = DetectedSenses(
        fls_id, world.ids, world.swarm.points, world.sensor, world.swarm.radius
    )
    assert senses.detect(np.array([10_000]), np.array([[5.0, 0.0, 0.0]])) == 0
    assert len(senses.measurement(fls_id).target_ids) == 0


def test_an_fls_senses_for_itself_only(world):
    fls_id = int(world.ids[0])
    senses = DetectedSenses(
        fls_id, world.ids, world.swarm.points, world.sensor, world.swarm.radius
    )
    with pytest.raises(UnknownFlsError):
        senses.view(int(world.ids[1]))
    with pytest.raises(UnknownFlsError):
        DetectedSenses(10_000, world.ids, world.swarm.points, world.sensor, world.swarm.radius)
