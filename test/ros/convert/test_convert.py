"""Messages built by ros.convert survive serialisation and read back as they were sent."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from swazure_interfaces.msg import MoveCommands, PathOffer, PoseEstimates, WorldState

from swazure_ros.core.estimators import TrackState
from swazure_ros.core.fit import LOCAL_LEAST_SQUARES, PATH, SWARM_FIT
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.observe import Measurement
from swazure_ros.core.relay import RELAY_OK
from swazure_ros.core.sensor import DECAYING, SWEET
from swazure_ros.core.tracking import TRACKING, MotionEstimate
from swazure_ros.files.sensors import load_sensor
from swazure_ros.protocol.discovery.estimate import Estimate
from swazure_ros.protocol.discovery.messages import (
    FIT,
    ROUND,
    SAMPLES,
    STALLED,
    START,
    STEP,
    SWEET_ALL,
    Broadcast,
    Control,
    FitOffer,
    FitStep,
    Offer,
    Report,
)
from swazure_ros.protocol.moves import RETURN, STEP_ASIDE, WALKING, Move, Walk
from swazure_ros.protocol.pulse import Alive
from swazure_ros.protocol.radio import Ack, Sent
from swazure_ros.protocol.tracking import (
    START_RELAY,
    RelayRequest,
    Sample,
    TrackProgressReport,
    TrackReport,
)
from swazure_ros.ros.convert.discovery import (
    ack_message,
    alive_from_message,
    control_from_message,
    control_message,
    estimates_from_message,
    estimates_message,
    heartbeat_message,
    moves_from_message,
    moves_message,
    pose_estimate_from_message,
    pose_estimate_message,
    sent_from_message,
    sent_message,
    walk_from_message,
    walk_message,
)
from swazure_ros.ros.convert.markers import scene_markers
from swazure_ros.ros.convert.offers import offer_from_message, offer_message
from swazure_ros.ros.convert.sensing import (
    camera_info_message,
    detections_from_message,
    detections_message,
    image_message,
    neighbour_fields,
    world_message,
    world_positions,
)
from swazure_ros.ros.convert.tracking import (
    PROGRESS_COUNTERS,
    motion_estimate,
    relay_request_from_message,
    relay_request_message,
    sample_from_message,
    sample_message,
    track_estimate_message,
    track_progress_from_message,
    track_progress_message,
)
from swazure_ros.ros.convert.units import (
    array3,
    centimetres,
    nanoseconds_stamp,
    stamp_nanoseconds,
    to_seconds,
    to_stamp,
    vector3,
)
from swazure_ros.ros.security.guard import MessageError

from ...conftest import FUZZ
from ..fuzz import message


def test_a_world_state_reads_back_every_id_and_position_bit_for_bit():
    ids = np.array([0, 3, 7, 4_000_000_000], dtype=np.int64)
    points = np.array([[0.1, -2.5, 3.0], [1e-9, 7.25, -0.0], [1 / 3, 2 / 3, 1.0], [5, 6, 7.5]])
    sent = world_message(12, ids, points, Time(sec=1))
    got = deserialize_message(serialize_message(sent), WorldState)
    read_ids, read_points = world_positions(got, ids, 1e6)
    assert got.revision == 12 and got.header.frame_id == "swarm"
    np.testing.assert_array_equal(read_ids, ids)
    np.testing.assert_array_equal(read_points, points)
    read_points[0, 0] = 99.0  # the caller's own array, not the message's buffer
    assert world_positions(got, ids, 1e6)[1][0, 0] == 0.1


def test_a_world_state_with_positions_missing_is_refused():
    message = world_message(1, np.arange(3), np.zeros((3, 3)), Time())
    message.positions = message.positions[:-3]
    with pytest.raises(MessageError, match="not 3 positions per FLS"):
        world_positions(message, np.arange(3), 1e6)


def test_moves_made_together_go_in_one_message_in_order():
    moves = [
        Move(5, STEP_ASIDE, 1, 2, 7, 2, np.array([0.5, 0.0, -0.25])),
        Move(9, RETURN, 1, 2, 7, 2, None),
    ]
    got = deserialize_message(serialize_message(moves_message(moves, Time())), MoveCommands)
    assert [command.fls_id for command in got.commands] == [5, 9]
    assert [command.kind for command in got.commands] == [STEP_ASIDE, RETURN]
    first = got.commands[0]
    assert (first.source_id, first.target_id) == (1, 2)
    assert (first.displacement.x, first.displacement.y, first.displacement.z) == (0.5, 0.0, -0.25)


def test_detections_are_taken_in_the_flss_own_frame_only():
    from geometry_msgs.msg import PoseWithCovariance
    from swazure_interfaces.msg import Detections, MarkerDetection

    from swazure_ros.core.errors import MessageError
    from swazure_ros.ros.convert.sensing import detections_from_message

    pose = PoseWithCovariance()
    pose.pose.position.x, pose.pose.position.y = 0.08, -0.01
    message = Detections(detections=[MarkerDetection(marker_id=9, pose=pose)])
    message.header.frame_id = "fls_3"
    markers, vectors = detections_from_message(message, 3)
    assert markers.tolist() == [9]
    assert vectors.tolist() == [[8.0, -1.0, 0.0]]  # cm
    with pytest.raises(MessageError, match="not fls_4"):
        detections_from_message(message, 4)  # another FLS's, or a camera's optical frame
    pose.pose.position.z = 1e307  # finite in metres, infinite in centimetres
    with pytest.raises(MessageError, match="beyond 10 km"):
        detections_from_message(message, 3)
    pose.pose.position.z = float("nan")
    with pytest.raises(MessageError, match="finite"):
        detections_from_message(message, 3)


def test_an_image_the_detector_cannot_read_is_refused_in_one_line():
    from sensor_msgs.msg import Image

    from swazure_ros.core.errors import MessageError
    from swazure_ros.ros.nodes.detector_node import grey_image

    with pytest.raises(MessageError, match="encoding"):
        grey_image(Image(encoding="16UC1", width=2, height=2, step=4, data=[0] * 8))
    with pytest.raises(MessageError, match="shorter"):
        grey_image(Image(encoding="mono8", width=4, height=4, step=4, data=[0] * 8))
    grey = grey_image(Image(encoding="bgr8", width=2, height=1, step=6, data=[0, 0, 255] * 2))
    assert grey.shape == (1, 2) and grey.dtype.name == "uint8"


def _found() -> Estimate:
    # FLS 3 -> 5 -> 9: 7.3 cm then 6.1 cm, summed as the swarm sums them.
    return Estimate(
        target=9,
        status=0,
        reason=0,
        path=(3, 5, 9),
        length=13.4,
        vector=np.array([7.3, -6.1, 0.25]),
        radio_path=(3, 9),
        predicted_error=0.12,
    )


def test_the_swarms_report_keeps_the_protocols_centimetres_to_the_bit():
    found = _found()
    report = Report(run_id=4, source=3, estimates=[found])
    message = deserialize_message(
        serialize_message(estimates_message(report, Time(sec=1))), PoseEstimates
    )
    (back,) = estimates_from_message(message, np.array([3, 5, 9]))
    assert (back.target, back.path, back.radio_path, back.length) == (9, (3, 5, 9), (3, 9), 13.4)
    assert (back.hops, back.predicted_error, back.estimator) == (2, 0.12, PATH)
    np.testing.assert_array_equal(back.vector, found.vector)
    assert back.covariance is None


def _report() -> Report:
    # Source 3: a sweet path to 9, a blocked pair with only a radio path to 7,
    # and 8 with no path at all.
    blocked = Estimate(target=7, status=2, reason=1, radio_path=(3, 5, 7))
    alone = Estimate(target=8, status=2, reason=2)
    return Report(run_id=4, source=3, estimates=[_found(), blocked, alone])


def test_a_report_is_one_array_entry_per_target():
    message = estimates_message(_report(), Time(sec=1))
    assert list(message.target_ids) == [9, 7, 8]
    assert list(message.path_offsets) == [0, 3, 3, 3]
    assert list(message.radio_path_offsets) == [0, 2, 5, 5]
    assert list(message.radio_path_ids) == [3, 9, 3, 5, 7]
    assert len(message.vectors) == 9


def test_a_report_without_covariances_sends_none_and_one_with_a_fit_nine_for_each():
    # Nine NaNs an estimate were 72 of a plain report's 170 bytes an estimate.
    assert len(estimates_message(_report(), Time(sec=1)).covariances) == 0
    fitted = replace(_found(), covariance=np.diag([1.0, 2.0, 3.0]))
    report = Report(run_id=4, source=3, estimates=[fitted, *_report().estimates[1:]])
    covariances = np.reshape(estimates_message(report, Time(sec=1)).covariances, (3, 3, 3))
    np.testing.assert_array_equal(covariances[0], np.diag([1.0, 2.0, 3.0]))
    assert np.isnan(covariances[1:]).all()


def test_every_estimate_of_a_report_reads_back_in_order():
    report = _report()
    message = wire(estimates_message(report, Time(sec=1)))
    back = estimates_from_message(message, np.array([3, 5, 7, 8, 9]))
    assert [one.target for one in back] == [9, 7, 8]
    assert [(one.status, one.reason) for one in back] == [(0, 0), (2, 1), (2, 2)]
    assert [one.path for one in back] == [(3, 5, 9), (), ()]
    assert [one.radio_path for one in back] == [(3, 9), (3, 5, 7), ()]
    assert [one.hops for one in back] == [2, 0, 0]
    assert np.isnan(back[1].vector).all() and np.isnan(back[2].length)
    assert all(one.covariance is None for one in back)


def test_a_report_without_covariances_holds_one_nan_for_all_and_with_one_each_its_own():
    # A coordinator holds every source's report until its run ends: millions of
    # estimates on a display, each with no covariance unless a fit made it.
    message = wire(estimates_message(_report(), Time(sec=1)))
    held = estimates_from_message(message, np.array([3, 5, 7, 8, 9])).covariance
    assert held.shape == (3, 3, 3) and np.isnan(held).all()
    assert held.strides == (0, 0, 0)  # one value, whatever the count
    fitted = replace(_found(), covariance=np.diag([1.0, 2.0, 3.0]))
    report = Report(run_id=4, source=3, estimates=[fitted, *_report().estimates[1:]])
    message = wire(estimates_message(report, Time(sec=1)))
    back = estimates_from_message(message, np.array([3, 5, 7, 8, 9]))
    assert back.covariance.strides != (0, 0, 0)
    np.testing.assert_allclose(back[0].covariance, np.diag([1.0, 2.0, 3.0]))
    assert back[1].covariance is None and back[2].covariance is None


def test_a_report_s_ids_are_held_in_the_wire_s_four_bytes():
    # A coordinator holds every source's report until its run ends: about ten ids an
    # estimate, millions of estimates on a display.
    message = wire(estimates_message(_report(), Time(sec=1)))
    held = estimates_from_message(message, np.array([3, 5, 7, 8, 9]))
    assert {held.targets.dtype, held.path_ids.dtype, held.radio_ids.dtype} == {np.dtype(np.uint32)}
    assert held.targets.tolist() == [9, 7, 8] and held.radio_ids.tolist() == [3, 9, 3, 5, 7]


def test_an_empty_report_reads_back_empty():
    message = wire(estimates_message(Report(run_id=4, source=3, estimates=[]), Time(sec=1)))
    assert estimates_from_message(message, np.array([3])) == []
    assert list(message.path_offsets) == [0] == list(message.radio_path_offsets)


@pytest.mark.parametrize(
    ("field", "value", "reason"),
    [
        ("statuses", [0, 2], "differ in length"),
        ("vectors", [0.0] * 8, "not 3 vector values"),
        ("covariances", [0.0] * 26, "not 9 covariance values"),
        ("covariances", [0.0] * 9, "not 9 covariance values per estimate, nor none"),
        ("path_offsets", [0, 3, 3], "one more path offset"),
        ("path_offsets", [0, 3, 3, 2], "do not span"),
        ("path_offsets", [0, 3, 1, 3], "decrease"),
        ("radio_path_ids", [3, 9, 3, 5, 6], "no FLS 6"),
        ("target_ids", [9, 7, 6], "no FLS 6"),
        ("statuses", [0, 2, 9], "unknown status"),
        ("estimators", [0, 0, 200], "unknown estimator"),
        ("path_lengths", [13.4, float("inf"), float("nan")], "not a finite number"),
        ("predicted_errors", [float("-inf"), 0.0, 0.0], "not a finite number"),
    ],
)
def test_a_malformed_report_is_one_message_error(field, value, reason):
    message = wire(estimates_message(_report(), Time(sec=1)))
    setattr(message, field, value)
    with pytest.raises(MessageError, match=reason):
        estimates_from_message(message, np.array([3, 5, 7, 8, 9]))


def test_a_report_longer_than_the_swarm_is_refused():
    message = wire(estimates_message(_report(), Time(sec=1)))
    with pytest.raises(MessageError, match="more than 2"):
        estimates_from_message(message, np.array([3, 9]))


def test_a_pose_estimate_for_people_is_in_metres_in_the_sources_frame():
    message = pose_estimate_message(3, _found(), Time(sec=1))
    assert message.header.frame_id == "fls_3" and message.source_id == 3
    assert (message.vector.x, message.vector.y, message.vector.z) == (0.073, -0.061, 0.0025)
    assert (message.path_length, message.predicted_error) == (0.134, 0.0012)
    back = pose_estimate_from_message(message)
    assert back.path == (3, 5, 9)
    np.testing.assert_allclose(back.vector, [7.3, -6.1, 0.25], rtol=1e-15)
    assert back.estimator == PATH and back.covariance is None


def test_a_fit_s_report_keeps_its_estimator_and_covariance():
    covariance = np.array([[4.0, 0.5, 0.0], [0.5, 2.0, -0.25], [0.0, -0.25, 1.0]]) * 1e-3
    fitted = replace(_found(), estimator=LOCAL_LEAST_SQUARES, covariance=covariance)
    report = Report(run_id=4, source=3, estimates=[fitted])
    message = deserialize_message(
        serialize_message(estimates_message(report, Time(sec=1))), PoseEstimates
    )
    (back,) = estimates_from_message(message, np.array([3, 5, 9]))
    assert back.estimator == LOCAL_LEAST_SQUARES
    np.testing.assert_array_equal(back.covariance, covariance)
    # For people: m^2, row-major.
    pose = pose_estimate_message(3, fitted, Time(sec=1))
    np.testing.assert_allclose(np.reshape(pose.covariance, (3, 3)), covariance * 1e-4, rtol=1e-15)
    np.testing.assert_allclose(pose_estimate_from_message(pose).covariance, covariance, rtol=1e-15)


def test_an_offer_of_a_fitting_run_carries_its_sums_and_one_without_carries_none():
    offer = Offer(
        source_ids=np.array([3]),
        hops=np.array([2]),
        lengths=np.array([13.4]),
        errors=np.array([0.2]),
        vectors=np.array([[7.3, -6.1, 0.25]]),
        path_offsets=np.array([0, 3]),
        path_ids=np.array([3, 5, 9]),
        unbiased=np.array([[7.2, -6.0, 0.24]]),
        covariances=np.arange(9.0).reshape(1, 3, 3),
    )
    swarm = np.array([3, 5, 9])
    message = deserialize_message(
        serialize_message(offer_message(Broadcast(1, 0, 2, 9, offer), Time())), PathOffer
    )
    back = offer_from_message(message, swarm)
    # Its paths' ids as the wire has them, uint32, as a process's own offers hold them.
    assert back.path_ids.tolist() == [3, 5, 9] and back.path_ids.dtype == np.uint32
    np.testing.assert_array_equal(back.unbiased, offer.unbiased)
    np.testing.assert_array_equal(back.covariances, offer.covariances)
    plain = offer_message(
        Broadcast(1, 0, 2, 9, replace(offer, unbiased=None, covariances=None)), Time()
    )
    assert offer_from_message(plain, swarm).covariances is None
    message.covariances = message.covariances[:-1]
    with pytest.raises(MessageError, match="9 covariance values per label"):
        offer_from_message(message, swarm)


# Every other converter, both ways through the wire: sent, serialised, read back.

SWARM = np.array([1, 3, 5, 9], dtype=np.int64)


def wire(message):
    """``message`` serialised and read back, as a subscriber gets it."""
    return deserialize_message(serialize_message(message), type(message))


def test_a_control_reads_back_as_it_was_sent():
    control = Control(
        run_id=7,
        command=START,
        phase=SWEET_ALL,
        policy="least-error",
        round=3,
        expected=4,
        source_ids=(1, 3),
        target_ids=(9, 5),
        finished_ids=(1,),
        departed_ids=(5,),
        estimator=LOCAL_LEAST_SQUARES,
    )
    assert control_from_message(wire(control_message(control, Time(sec=2))), SWARM) == control


def test_a_round_ack_carries_its_host_and_counts():
    ack = Ack(run_id=7, phase=SWEET_ALL, round=3, heard=12, repairs=2, lost=1, latency=0.5)
    got = wire(ack_message(ack, "host_1", Time(sec=2)))
    assert (got.run_id, got.phase, got.round, got.heard) == (7, SWEET_ALL, 3, 12)
    assert (got.repairs, got.lost, got.host, got.header.stamp.sec) == (2, 1, "host_1", 2)


def test_a_heartbeat_reads_back_what_its_radio_said():
    alive = Alive("fls_12", True, 7, 3, 2.5)
    got = wire(heartbeat_message(alive, Time(sec=2)))
    assert alive_from_message(got) == alive and got.header.stamp.sec == 2


@pytest.mark.parametrize("late", [float("nan"), -1.0, float("inf"), 1e7])
def test_a_heartbeat_late_by_no_time_is_refused(late):
    message = heartbeat_message(Alive("fls_1", False, 0, 0, 0.0), Time())
    message.late = late
    with pytest.raises(MessageError, match="late"):
        alive_from_message(message)


def test_moves_read_back_as_commanded_kinds_and_displacements():
    moves = [
        Move(5, STEP_ASIDE, 1, 9, 7, 2, np.array([0.5, 0.0, -0.25])),
        Move(3, RETURN, 1, 9, 7, 2, None),
    ]
    ids, kinds, displacement = moves_from_message(wire(moves_message(moves, Time())), SWARM, 10.0)
    assert ids.tolist() == [5, 3] and kinds.tolist() == [STEP_ASIDE, RETURN]
    np.testing.assert_array_equal(displacement[0], [0.5, 0.0, -0.25])


def test_a_walk_reads_back_at_its_hop_with_its_sum():
    walk = Walk(7, 4, (1, 3, 9), hop=1, state=WALKING, vector=np.array([7.3, -6.1, 0.25]))
    back = walk_from_message(wire(walk_message(walk, Time())), SWARM)
    assert (back.run_id, back.revision, back.path, back.hop, back.state) == (7, 4, (1, 3, 9), 1, 0)
    np.testing.assert_array_equal(back.vector, walk.vector)


def test_detections_read_back_as_the_vectors_the_camera_measured():
    measurement = Measurement(
        np.array([9, 5]),
        np.array([SWEET, DECAYING], dtype=np.int8),
        np.array([[7.3, -6.1, 0.25], [1.0, 2.0, 3.0]]),
        np.array([6.5, 9.0]),
    )
    sensor = load_sensor()
    sent = detections_message(3, measurement, np.array([42, 17]), sensor, Time(sec=1), revision=4)
    got = wire(sent)
    markers, vectors = detections_from_message(got, 3)
    assert markers.tolist() == [42, 17] and got.revision == 4
    np.testing.assert_allclose(vectors, measurement.vector, rtol=1e-15)


def test_a_relay_request_and_a_sample_read_back_to_the_nanosecond():
    request = RelayRequest(START_RELAY, source=1, relay=3, target=9, start=1_500_000_001)
    assert relay_request_from_message(wire(relay_request_message(request)), SWARM) == request
    sample = Sample(1, 3, 9, RELAY_OK, np.array([7.3, -6.1, 0.25]), 2_000_000_003)
    back = sample_from_message(wire(sample_message(sample)), SWARM)
    assert (back.source, back.relay, back.target, back.status, back.sensed) == (
        1, 3, 9, RELAY_OK, 2_000_000_003
    )  # fmt: skip
    np.testing.assert_allclose(back.position, sample.position, rtol=1e-15)


def test_track_progress_reads_back_with_every_counter():
    traffic = Counter({name: index + 1 for index, name in enumerate(PROGRESS_COUNTERS)})
    report = TrackProgressReport(3, 2_000_000_003, traffic, True)
    assert track_progress_from_message(wire(track_progress_message(report)), SWARM) == report


def test_a_track_estimate_reads_back_as_the_sources_estimate():
    state = TrackState(2.0, np.array([1.0, 2.0, 3.0]), np.array([0.5, 0, 0]), np.zeros(3))
    filtered = TrackState(1.75, np.array([0.9, 2.0, 3.0]), np.array([0.5, 0, 0]), np.zeros(3))
    estimate = MotionEstimate(
        TRACKING, 2.0, 1.75, np.array([0.9, 2.0, 3.1]), state, filtered,
        np.array([0.4, 0, 0]), np.zeros(3), "", relay=3,
    )  # fmt: skip
    back = motion_estimate(
        wire(track_estimate_message(TrackReport(1, 9, "constant-velocity", estimate)))
    )
    assert (back.status, back.time, back.sample_time, back.relay) == (TRACKING, 2.0, 1.75, 3)
    for ours, theirs in ((back.kalman, state), (back.filtered, filtered)):
        assert ours is not None and ours.time == theirs.time
        np.testing.assert_allclose(ours.position, theirs.position, rtol=1e-15)
        np.testing.assert_allclose(ours.velocity, theirs.velocity, rtol=1e-15)
    np.testing.assert_allclose(back.raw, estimate.raw, rtol=1e-15)


def test_stamps_and_vectors_convert_both_ways():
    assert stamp_nanoseconds(wire(nanoseconds_stamp(2_000_000_003))) == 2_000_000_003
    assert to_seconds(wire(to_stamp(1.25))) == 1.25
    vector = np.array([0.073, -0.061, 0.0025])
    np.testing.assert_array_equal(array3(wire(vector3(vector))), vector)
    np.testing.assert_allclose(centimetres(vector3(vector)), vector * 100, rtol=1e-15)
    assert np.isnan(array3(vector3(None))).all()


def test_a_camera_image_and_its_calibration_read_back():
    from swazure_ros.files.reading import config_dir
    from swazure_ros.files.sensors import load_camera

    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    image = np.arange(12, dtype=np.uint8).reshape(3, 4)
    got = wire(image_message(image, Time(sec=1), "fls_3_camera_optical"))
    assert (got.height, got.width, got.encoding, got.header.frame_id) == (
        3, 4, "mono8", "fls_3_camera_optical"
    )  # fmt: skip
    np.testing.assert_array_equal(np.frombuffer(bytes(got.data), np.uint8).reshape(3, 4), image)
    info = wire(camera_info_message(camera, Time(sec=1), "fls_3_camera_optical"))
    assert (info.width, info.height) == (camera.width, camera.height)
    assert info.header.frame_id == "fls_3_camera_optical"
    np.testing.assert_array_equal(np.reshape(info.k, (3, 3)), camera.matrix)


def test_neighbour_sets_fill_the_get_neighbours_answer():
    from swazure_interfaces.srv import GetNeighbours

    from swazure_ros.core.observe import NeighbourSets

    sets = NeighbourSets(np.array([1]), np.array([3, 5]), np.array([3]), np.array([9]))
    response = GetNeighbours.Response(**neighbour_fields(sets))
    got = wire(response)
    assert (got.blind_ids.tolist(), got.sweet_ids.tolist()) == ([1], [3, 5])
    assert (got.visible_sweet_ids.tolist(), got.decaying_ids.tolist()) == ([3], [9])


def test_a_scene_becomes_markers_in_metres_in_the_swarm_frame():
    from visualization_msgs.msg import MarkerArray

    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.view.scene import ranges_scene

    swarm = make_swarm(np.array([[0.0, 0, 0], [7.0, 0, 0], [0, 7.0, 0]]), radius=0.5)
    hood = neighbourhood(swarm, load_sensor())
    got = wire(scene_markers(ranges_scene(hood, "three FLSs", 0), Time(sec=1)))
    assert isinstance(got, MarkerArray)
    flss = next(marker for marker in got.markers if marker.ns == "flss")
    points = np.array([[p.x, p.y, p.z] for p in flss.points])
    np.testing.assert_allclose(points, swarm.points / 100)


@settings(FUZZ, max_examples=300)
@given(data=st.data())
def test_generated_detections_are_taken_or_refused_and_nothing_else(data):
    """Any Detections a peer could publish (header, markers, poses, revision): the FLS's
    conversion gives markers and finite vectors, or one MessageError; never another error."""
    from swazure_interfaces.msg import Detections

    from swazure_ros.core.errors import MessageError
    from swazure_ros.ros.convert.sensing import detections_from_message

    generated = data.draw(message(Detections, [0, 1, 2, 3]))
    if data.draw(st.booleans()):
        generated.header.frame_id = "fls_3"  # past the frame check, to the readings
    try:
        markers, vectors = detections_from_message(generated, 3)
    except MessageError:
        return
    assert len(markers) == len(vectors) == len(generated.detections)
    assert np.isfinite(vectors).all()


def test_the_fit_phase_s_control_offer_and_sums_read_back_and_bad_ones_are_refused():
    step = FitStep(STEP, 1, SAMPLES, (0.25, -1.5e-12, 3.0, 4.0), STALLED)
    control = Control(7, ROUND, FIT, "shortest-length", 9, 4, estimator=SWARM_FIT, fit=step)
    message = wire(control_message(control, Time()))
    assert control_from_message(message, SWARM) == control
    message.fit_stage = 7
    with pytest.raises(MessageError, match="unknown fit stage"):
        control_from_message(message, SWARM)
    said = FitOffer(label=3, values=np.array([1.0, -2.0, 0.5, 4.0, 5.0, 6.0]))
    empty = np.zeros(0, dtype=np.int64)
    offer = Offer(empty, empty, np.zeros(0), np.zeros(0), np.zeros((0, 3)),
                  np.zeros(1, dtype=np.int64), empty, pending=True, fit=said)  # fmt: skip
    back = offer_from_message(wire(offer_message(Broadcast(7, FIT, 9, 5, offer), Time())), SWARM)
    assert back.fit is not None and back.fit.label == 3
    np.testing.assert_array_equal(back.fit.values, said.values)
    for field, value, reason in (
        ("fit_label", 4, "no FLS 4 in this swarm"),
        ("fit_values", [1.0, 2.0], "not 3 fit values a column"),
        ("fit_values", [1.0, float("inf"), 0.0], "finite"),
    ):
        bad = wire(offer_message(Broadcast(7, FIT, 9, 5, offer), Time()))
        setattr(bad, field, value)
        with pytest.raises(MessageError, match=reason):
            offer_from_message(bad, SWARM)
    sent = Sent((3, 5), 0, (3,), (), 120, (1.5, -2.25), 0.125, (True, False))
    assert sent_from_message(wire(sent_message(control, sent, "host_1", Time())), SWARM) == sent
    negative = wire(sent_message(control, replace(sent, fit_moved=-1.0), "host_1", Time()))
    with pytest.raises(MessageError, match="negative move"):
        sent_from_message(negative, SWARM)


def test_the_fls_frames_of_each_revision_are_where_the_flss_are_now_in_metres():
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    from swazure_ros.ros.convert.sensing import FlsFrames
    from swazure_ros.ros.plumbing.cdr import serialize

    def by_hand(ids, metres, stamp):
        message = TFMessage()
        for fls_id, (x, y, z) in zip(ids, metres, strict=True):
            frame = TransformStamped(child_frame_id=f"fls_{fls_id}")
            frame.header.frame_id, frame.header.stamp = "swarm", stamp
            translation = frame.transform.translation
            translation.x, translation.y, translation.z = x, y, z
            frame.transform.rotation.w = 1.0
            message.transforms.append(frame)
        return serialize(message)

    # Names of several lengths, so that the frames' fields lie unevenly aligned.
    ids = [3, 7, 12, 4096, 100000]
    frames = FlsFrames(np.array(ids))
    points = np.array([[100.0, 0, 0], [0, 50, 0], [-3, 2.5, 1e-3], [7, 8, 9], [0, 0, 0]])
    stamp = Time(sec=1, nanosec=2**31 + 5)  # above int32's range
    assert frames.serialized(points, stamp) == by_hand(ids, (points / 100).tolist(), stamp)
    points[1] = [0, 50, 25]  # FLS 7 moves: the next revision's bytes say so
    later = Time(sec=2, nanosec=5)
    sent = frames.serialized(points, later)
    assert sent == by_hand(ids, (points / 100).tolist(), later)
    frame = deserialize_message(sent, TFMessage).transforms[1]
    t = frame.transform.translation
    assert (frame.child_frame_id, t.x, t.y, t.z) == ("fls_7", 0.0, 0.5, 0.25)
