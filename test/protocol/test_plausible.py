"""What a receiver checks of a path label: forged labels fail, every honest label passes."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.hop_errors import hop_error
from swazure_ros.protocol.discovery.messages import (
    ANY_VISIBLE,
    SWEET_ALL,
    SWEET_VISIBLE,
    Offer,
)
from swazure_ros.protocol.plausible import (
    REASONS,
    implausible,
    implausible_labels,
    offer_readings_check,
)
from swazure_ros.protocol.radio import RadioHub
from swazure_ros.sim.world import WorldSpec

from ..conftest import SCENE, A, B, C, D
from .test_discovery import run

RADIUS = 0.5


def positions(ids):
    return SCENE[ids]


def label(path, sensor, vector=None, length=None, error=None):
    """One FLS's offer of one honest label along ``path`` (scene indices as ids)."""
    hops = np.linalg.norm(np.diff(SCENE[list(path)], axis=0), axis=1) - 2 * RADIUS
    true = SCENE[path[-1]] - SCENE[path[0]]
    return Offer(
        source_ids=np.array([path[0]]),
        hops=np.array([len(path) - 1]),
        lengths=np.array([hops.sum() if length is None else length]),
        errors=np.array([hop_error(sensor, hops, RADIUS).sum() if error is None else error]),
        vectors=np.array([true if vector is None else vector], dtype=np.float64),
        path_offsets=np.array([0, len(path)]),
        path_ids=np.array(path),
    )


def test_an_honest_sweet_label_is_plausible(sensor):
    # A -> B -> C: two sweet hops (t = 6.28 cm); the vector is within the sensor's bias.
    assert implausible(label([A, B, C], sensor), SWEET_VISIBLE, positions, sensor, RADIUS) is None


def test_the_issues_forged_label_over_a_blind_pair_is_not(sensor):
    # A and C are blind to each other: no sweet hop joins them.
    forged = label([A, C], sensor, vector=[123.0, 456.0, 789.0], length=7.0, error=0.1)
    why = implausible(forged, SWEET_VISIBLE, positions, sensor, RADIUS)
    assert why == "a hop of a path is not in range"


def test_a_decaying_hop_is_in_range_only_in_the_decaying_phase(sensor):
    honest = label([A, D, C], sensor)
    assert implausible(honest, ANY_VISIBLE, positions, sensor, RADIUS) is None
    assert implausible(honest, SWEET_ALL, positions, sensor, RADIUS) is not None


@pytest.mark.parametrize(
    ("change", "reason"),
    [
        ({"length": 20.0}, "a length is not its path's"),
        ({"error": 0.0}, "an expected error is not its path's"),
        ({"vector": [4.0, 0.5, 0.0]}, "a vector is beyond the sensor's error bounds"),
    ],
)
def test_a_label_whose_sums_are_not_its_path_is_not_plausible(sensor, change, reason):
    forged = label([A, B, C], sensor, **change)
    assert implausible(forged, SWEET_VISIBLE, positions, sensor, RADIUS) == reason


def test_a_vector_within_the_bias_of_each_hop_passes_and_just_beyond_fails(sensor):
    path = [A, B, C]
    hops = np.linalg.norm(np.diff(SCENE[path], axis=0), axis=1) - 2 * RADIUS
    bound = np.abs(hops * sensor.relative_error(hops)).sum()
    true = SCENE[C] - SCENE[A]
    inside = label(path, sensor, vector=true + np.array([0.0, 0.99 * bound, 0.0]))
    outside = label(path, sensor, vector=true + np.array([0.0, 1.01 * bound, 0.0]))
    assert implausible(inside, SWEET_VISIBLE, positions, sensor, RADIUS) is None
    assert implausible(outside, SWEET_VISIBLE, positions, sensor, RADIUS) is not None


@pytest.mark.parametrize("phase", [SWEET_VISIBLE, ANY_VISIBLE])
def test_a_round_s_labels_each_get_their_own_verdict(sensor, phase):
    """Checked as one round, each label is judged by its own hops and sums alone: a forged
    label beside honest ones, and a source's own label (a path of one FLS, no hop), first,
    between and last, neither pass nor fail for their neighbours in the flat arrays."""
    own = label([B], sensor)  # a source's label of itself: no hop, nothing summed
    labels = [
        own,
        label([A, B, C], sensor),
        label([A, C], sensor, vector=[4.0, 0.0, 0.0], length=3.0, error=0.1),  # blind hop
        own,
        label([A, D, C], sensor),  # decaying hops: in range in the decaying phase only
        label([C, B, A], sensor, length=20.0),
        label([C, B, A], sensor, error=0.0),
        label([A, B], sensor, vector=SCENE[B] - SCENE[A] + [0.0, 0.0, 1.0]),
        own,
    ]
    offsets = np.cumsum([0] + [len(one.path_ids) for one in labels])
    why = implausible_labels(
        np.concatenate([one.lengths for one in labels]),
        np.concatenate([one.errors for one in labels]),
        np.concatenate([one.vectors for one in labels]),
        offsets,
        np.concatenate([one.path_ids for one in labels]).astype(np.uint32),
        phase,
        positions,
        sensor,
        RADIUS,
    )
    decaying = "" if phase == ANY_VISIBLE else "a hop of a path is not in range"
    assert [REASONS[code] for code in why] == [
        "",
        "",
        "a hop of a path is not in range",
        "",
        decaying,
        "a length is not its path's",
        "an expected error is not its path's",
        "a vector is beyond the sensor's error bounds",
        "",
    ]
    # Each alone says the same.
    alone = [implausible(one, phase, positions, sensor, RADIUS) or "" for one in labels]
    assert alone == [REASONS[code] for code in why]


def test_under_a_camera_a_vector_may_miss_by_each_hop_s_length_and_no_more(sensor):
    """A rendering camera has no error model: a hop may be off by its centre distance
    (t + 2r), and a path by the sum over its hops. The place that ends a path is not a hop
    and lends no slack, though a camera's bound at a tracking distance of 0 is 2r."""
    from swazure_ros.files.reading import config_dir
    from swazure_ros.files.sensors import load_camera

    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    under_camera = replace(sensor, camera=camera)
    path = [A, B, C]
    hops = np.linalg.norm(np.diff(SCENE[path], axis=0), axis=1) - 2 * RADIUS
    slack = (hops + 2 * RADIUS).sum()
    true = SCENE[C] - SCENE[A]

    def verdict(path, vector):
        return implausible(
            label(path, under_camera, vector=vector),
            SWEET_VISIBLE,
            positions,
            under_camera,
            RADIUS,
        )

    assert verdict(path, true + np.array([0.0, 0.0, 0.99 * slack])) is None
    # 2r more than the hops allow: what the path's last place would lend if it counted.
    beyond = "a vector is beyond the sensor's error bounds"
    assert verdict(path, true + np.array([0.0, 0.0, slack + RADIUS])) == beyond
    assert verdict([B], [0.0, 0.0, RADIUS]) == beyond  # a source's own label: no hop at all


@pytest.mark.parametrize(
    "sensor_file", ["config/sensor.yaml", "config/cameras/sensor-wide-calibrated.yaml"]
)
@pytest.mark.parametrize("policy", ["shortest-length", "least-error"])
def test_every_label_of_an_honest_run_is_plausible(monkeypatch, sensor_file, policy):
    """No false alarm: every broadcast of a whole in-memory run passes the receivers' check."""
    world = WorldSpec("torus:120", scale=1.6, beta=0.5, sensor_file=sensor_file).build()
    points = world.swarm.points
    phases = Counter()
    take = RadioHub.on_offers
    readings = offer_readings_check(
        lambda ids: points[world.indices(ids)], world.sensor, world.swarm.radius
    )
    read = Counter()

    def checking(hub, run_id, round_, offers):
        # Every offer the run makes is heard by its process's radio, in one call a round.
        for out in offers:
            why = implausible(
                out.offer,
                out.phase,
                lambda ids: points[world.indices(ids)],
                world.sensor,
                world.swarm.radius,
            )
            assert why is None, (out.sender, out.phase, out.round, why)
            phases[out.phase] += len(out.offer)
            if len(out.offer.reading_ids):
                assert readings(out.sender, out.offer) is None, out.sender
                read[out.phase] += len(out.offer.reading_ids)
        return take(hub, run_id, round_, offers)

    monkeypatch.setattr(RadioHub, "on_offers", checking)
    run(world.hood, policy)
    assert all(phases[phase] > 100 for phase in (SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE)), phases
    # Only where a pair's two ends read it differently do offers carry readings.
    assert (sum(read.values()) > 1000) == (world.sensor.noise is not None), read


def test_a_reading_beyond_the_sensor_s_bounds_or_out_of_camera_range_is_not(sensor):
    check = offer_readings_check(positions, sensor, RADIUS)
    true = SCENE[[B, D]] - SCENE[A]
    honest = replace(label((A, B), sensor), reading_ids=np.array([B, D]), reading_vectors=true)
    assert check(A, honest) is None
    forged = replace(honest, reading_vectors=true + np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 0.0]]))
    assert check(A, forged) == "a reading is beyond the sensor's error bounds"
    blind = replace(honest, reading_ids=np.array([C]), reading_vectors=SCENE[[C]] - SCENE[A])
    assert check(A, blind) == "a reading is not in camera range"
