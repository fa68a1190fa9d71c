"""The rendering camera: known poses in, poses out; the blind zone; determinism."""

from dataclasses import replace

import cv2
import numpy as np
import pytest

from swazure_ros.camera.aruco import (
    Detector,
    MarkerPose,
    full_image,
    measure,
    render,
    true_centre,
)
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera

CAMERAS = config_dir() / "cameras"


@pytest.fixture(scope="module")
def wide():
    return load_camera(CAMERAS / "rpi-camera-module-3-wide.yaml")


@pytest.fixture(scope="module")
def sharp(wide):
    """The wide camera, linear and measured with a small corner window: no bias, only noise."""
    return replace(
        wide, degradations=replace(wide.degradations, corner_window_px=3, tone_gamma=1.0)
    )


@pytest.fixture(scope="module")
def standard():
    return load_camera(CAMERAS / "rpi-camera-module-3-standard.yaml")


def detections(camera, distance_mm, frames=30, seed=0, **pose):
    rng = np.random.default_rng(seed)
    detector = Detector(camera)
    found = [
        measure(
            camera, MarkerPose(distance_mm, roll_deg=rng.uniform(0, 360), **pose), rng, detector
        )
        for _ in range(frames)
    ]
    return [f for f in found if f is not None]


@pytest.mark.parametrize("distance_mm", [60.0, 80.0, 120.0, 180.0])
def test_head_on_marker_is_measured_at_its_distance_and_direction(sharp, distance_mm):
    # Noise scatters a frame by a few per cent where the marker is small; the mean stays close.
    found = detections(sharp, distance_mm, frames=12)
    assert len(found) >= 11
    truth = true_centre(sharp, MarkerPose(distance_mm))
    lengths = np.linalg.norm(found, axis=1)
    assert np.mean(lengths) == pytest.approx(np.linalg.norm(truth), rel=0.02)
    assert np.all(np.abs(lengths / np.linalg.norm(truth) - 1) < 0.05)
    for centre in found:
        cosine = centre @ truth / np.linalg.norm(centre) / np.linalg.norm(truth)
        assert np.degrees(np.arccos(min(cosine, 1.0))) < 0.5


def test_the_transfer_curve_makes_blurred_markers_look_smaller_and_farther(wide, sharp):
    # Light blurs in linear intensity; the frame's curve then lifts the mixed pixels at the
    # black border's edges toward white, and the black square shrinks.
    curved = replace(sharp, degradations=replace(sharp.degradations, tone_gamma=2.2))
    far = 180.0
    truth = np.linalg.norm(true_centre(wide, MarkerPose(far)))
    linear = np.mean(np.linalg.norm(detections(sharp, far, frames=20), axis=1)) / truth - 1
    gamma = np.mean(np.linalg.norm(detections(curved, far, frames=20), axis=1)) / truth - 1
    assert gamma > linear + 0.01


def test_fitted_corner_window_overestimates_far_markers_as_the_real_camera_does(wide, sharp):
    far = 170.0
    truth = np.linalg.norm(true_centre(wide, MarkerPose(far)))
    fitted = np.mean([np.linalg.norm(c) for c in detections(wide, far, frames=20)]) / truth - 1
    unbiased = np.mean([np.linalg.norm(c) for c in detections(sharp, far, frames=20)]) / truth - 1
    assert fitted > 0.08 and abs(unbiased) < 0.02


def test_marker_off_the_axis_is_seen_in_its_direction(sharp):
    pose = MarkerPose(90.0, offset_px=(150.0, -80.0))
    truth = true_centre(sharp, pose)
    centre = measure(sharp, pose, np.random.default_rng(3))
    assert centre is not None
    cosine = centre @ truth / np.linalg.norm(centre) / np.linalg.norm(truth)
    assert np.degrees(np.arccos(min(cosine, 1.0))) < 0.5
    assert centre[0] > 0 > centre[1]


def test_tilted_marker_is_measured_at_its_distance(sharp):
    found = detections(sharp, 80.0, frames=10, tilt_deg=40.0)
    assert len(found) >= 9
    truth = np.linalg.norm(true_centre(sharp, MarkerPose(80.0)))
    assert np.mean([np.linalg.norm(c) for c in found]) == pytest.approx(truth, rel=0.03)


@pytest.mark.parametrize("name", ["wide", "standard"])
def test_blind_zone_lies_below_the_closest_focus_and_only_there(name, request):
    camera = request.getfixturevalue(name)
    focus = camera.focus_min_mm
    assert len(detections(camera, 0.6 * focus)) < 15  # under half of 30 frames
    for factor in (1.0, 1.3, 2.0):
        assert len(detections(camera, factor * focus)) >= 28, factor


def test_lens_parked_at_its_near_stop_blurs_a_nearer_marker_only(wide):
    assert wide.defocus_px(50.0, 50.0) == 0.0
    assert wide.defocus_px(40.0, 50.0) > 4.0
    # Thin lens: blur A f |1/d - 1/s| / (1 - f/s), here at 40 mm: 1.25 * 2.75 * 0.005 / 0.945 mm.
    expected_mm = (2.75 / 2.2) * 2.75 * (1 / 40 - 1 / 50) / (1 - 2.75 / 50)
    assert wide.defocus_px(40.0, 50.0) == pytest.approx(expected_mm / wide.pixel_pitch_mm)


def test_same_seed_same_frame_and_measurement(wide):
    pose = MarkerPose(120.0, roll_deg=33.0)
    first = render(wide, pose, np.random.default_rng(7))
    second = render(wide, pose, np.random.default_rng(7))
    other = render(wide, pose, np.random.default_rng(8))
    assert np.array_equal(first.image, second.image)
    assert not np.array_equal(first.image, other.image)
    a = measure(wide, pose, np.random.default_rng(7))
    b = measure(wide, pose, np.random.default_rng(7))
    assert np.array_equal(a, b)


def test_region_of_interest_detects_as_the_whole_frame_does(wide):
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_100)
    whole_frame = cv2.aruco.ArucoDetector(dictionary, cv2.aruco.DetectorParameters())
    detector = Detector(wide)
    rng = np.random.default_rng(1)
    found = 0
    for distance in (40.0, 48.0, 55.0, 100.0, 180.0, 260.0):
        for tilt in (0.0, 30.0, 60.0):
            pose = MarkerPose(distance, tilt_deg=tilt, roll_deg=float(rng.uniform(0, 360)))
            frame = render(wide, pose, rng)
            corners, ids, _ = whole_frame.detectMarkers(full_image(wide, frame))
            roi, roi_ids, _ = detector._detector_for(frame.image.shape).detectMarkers(frame.image)
            assert (ids is None) == (roi_ids is None), (distance, tilt)
            if ids is not None:
                found += 1
                np.testing.assert_allclose(
                    roi[0].reshape(4, 2) + frame.origin, corners[0].reshape(4, 2), atol=1e-3
                )
    assert found >= 10


def test_wide_and_standard_share_every_degradation(wide, standard):
    # Same sensor, marker and measurement; only the lens differs (issue 17).
    assert wide.degradations == standard.degradations
    assert (wide.marker_side_mm, wide.marker_dictionary) == (
        standard.marker_side_mm,
        standard.marker_dictionary,
    )


@pytest.mark.parametrize(
    "intrinsics",
    [{"fx": 1e-300, "fy": 1e-300}, {"cx": 1e300, "cy": 1e300}, {"fx": 1e-100}],
    ids=["fx=fy=1e-300", "cx=cy=1e300", "fx=1e-100"],
)
def test_a_solve_that_is_not_finite_finds_no_pose(wide, intrinsics):
    # Intrinsics that no camera file passes can still come from a camera driver's
    # camera_info: the solve then says "no pose" rather than hand on a NaN centre.
    frame = render(wide, MarkerPose(65.0), np.random.default_rng(0))
    corners = Detector(wide).corners(frame)
    assert corners is not None
    assert np.all(np.isfinite(Detector(wide).solve(corners)))
    assert Detector(replace(wide, **intrinsics)).solve(corners) is None


def test_marker_too_close_to_the_lens_is_not_detected(wide):
    tiny = replace(wide, focus_min_mm=50.0)
    assert measure(tiny, MarkerPose(5.0), np.random.default_rng(0)) is None
