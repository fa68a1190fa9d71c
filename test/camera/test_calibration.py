"""Calibration: ranges from a sweep by the documented criteria, and the fit to measured data."""

import math

import numpy as np
import pytest

from swazure_ros.camera.calibration import (
    Criteria,
    MarkerSweep,
    Sweep,
    blind_limit_mm,
    compare,
    crossing,
    marker_sweep,
    search_ranges,
    sensor_from_sweep,
    sweep,
)
from swazure_ros.core.errors import SensorError
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera, load_measured

from ..conftest import SHARED

MEASURED = SHARED / "datasets" / "aruco-measured" / "rpi-camera-module-3-wide.csv"


def hand_sweep():
    """Ten distances, 40..130 mm: blind up to 50, clean from 60, drifting from 100, lost at 130."""
    distances = np.arange(40.0, 140.0, 10.0)
    detection = np.array([0.0, 0.2, 0.8, 1.0, 1.0, 1.0, 1.0, 0.9, 0.6, 0.2])
    error = np.array([np.nan, 0.05, 0.03, 0.01, 0.005, 0.01, 0.04, 0.08, 0.15, 0.4])
    column = lambda values: values.reshape(-1, 1)  # noqa: E731
    return Sweep(
        distances,
        np.array([0.0]),
        100,
        column(detection),
        column(error),
        column(np.full(10, 0.01)),
        column(np.full(10, 0.2)),
        0.001,
    )


def test_crossing_interpolates_where_the_rate_passes_the_level():
    distances = np.array([40.0, 50.0, 60.0])
    assert crossing(distances, np.array([0.2, 0.8, 1.0]), 0.5, rising=True) == pytest.approx(45.0)
    assert math.isnan(crossing(distances, np.array([0.6, 0.8, 1.0]), 0.5, rising=True))
    assert crossing(distances, np.array([1.0, 0.8, 0.2]), 0.5, rising=False) == pytest.approx(55.0)


def test_ranges_follow_the_documented_criteria():
    sensor = sensor_from_sweep(
        hand_sweep(), Criteria(detection=0.5, sweet_detection=0.95, sweet_error=0.02)
    )
    # Detection passes 50 % at 55 mm, but the error is 3 % at 60: sweet where detection >= 95 %
    # and error <= 2 %, 70 to 90 mm, up to the first distance that fails (100); decaying from
    # there until detection falls under 50 % (120 + 10 * 0.1 / 0.4 = 122.5 mm).
    assert (sensor.sweet_min, sensor.sweet_max) == (7.0, 10.0)
    assert sensor.decaying_min == 10.0
    assert sensor.decaying_max == pytest.approx(12.25)
    assert blind_limit_mm(
        hand_sweep().distances_mm, hand_sweep().detection[:, 0]
    ) == pytest.approx(55.0)
    # The error table keeps the measured means where most frames detect, the nearest elsewhere.
    np.testing.assert_allclose(sensor.relative_error([6.0, 10.0, 13.0]), [0.03, 0.04, 0.15])
    assert sensor.noise.detection[0] == 0.0


def test_a_camera_that_never_detects_is_an_error():
    blind = hand_sweep()
    nothing = Sweep(
        blind.distances_mm,
        blind.angles_deg,
        100,
        np.zeros_like(blind.detection),
        np.full_like(blind.mean_error, np.nan),
        blind.distance_sd,
        blind.direction_sd_deg,
        0.0,
    )
    with pytest.raises(SensorError, match="never detects"):
        sensor_from_sweep(nothing)


def test_the_pattern_moves_the_error_only_where_the_window_reaches_the_bits():
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    # At 50 mm a cell is 13 px, beyond the 11 px window; at 100 mm it is 6.6 px.
    result = marker_sweep(camera, (50.0, 100.0), (0, 1, 22), frames=6, seed=3)
    near, far = result.mean_error[:, 0], result.mean_error[:, 1]
    assert np.ptp(near) < 0.001
    assert np.ptp(far) > 0.02
    # Each row is the plain sweep of the camera carrying that marker.
    from dataclasses import replace

    one = sweep(replace(camera, marker_id=22), (50.0, 100.0), (0.0,), frames=6, seed=3)
    np.testing.assert_array_equal(result.mean_error[2], one.mean_error[:, 0])


def test_markers_rank_by_mean_absolute_error_where_they_detect_ties_by_id():
    result = MarkerSweep(
        np.array([0, 1, 2, 3]),
        np.array([50.0, 100.0]),
        10,
        detection=np.array([[1.0, 1.0], [1.0, 0.2], [1.0, 1.0], [0.1, 0.0]]),
        # id 1's 100 mm mean rests on 2 frames of 10 and does not count.
        # Means exact in binary, so that the three ties are exact.
        mean_error=np.array([[0.125, -0.375], [0.25, 0.90], [-0.5, 0.0], [0.0, np.nan]]),
    )
    ids, score = result.least_error()
    assert ids.tolist() == [0, 1, 2, 3]
    assert score.tolist() == [0.25, 0.25, 0.25, np.inf]


def test_a_sweep_over_markers_shows_them_in_turn():
    from dataclasses import replace

    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    alone = sweep(replace(camera, marker_id=22), (100.0,), (0.0,), frames=20, seed=1)
    np.testing.assert_array_equal(
        sweep(camera, (100.0,), (0.0,), frames=20, seed=1, markers=(22,)).mean_error,
        alone.mean_error,
    )
    # Id 0 errs about 5.5 % at 100 mm, id 22 about 2 %: frames alternating between them
    # land in between.
    own = sweep(camera, (100.0,), (0.0,), frames=20, seed=1).mean_error[0, 0]
    mixed = sweep(camera, (100.0,), (0.0,), frames=20, seed=1, markers=(0, 22)).mean_error[0, 0]
    assert alone.mean_error[0, 0] + 0.01 < mixed < own - 0.01


def test_sweep_is_deterministic_and_each_point_has_its_own_stream():
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    first = sweep(camera, (60.0, 120.0), (0.0,), frames=4, seed=5)
    again = sweep(camera, (60.0, 120.0), (0.0,), frames=4, seed=5)
    alone = sweep(camera, (120.0,), (0.0,), frames=4, seed=5)
    np.testing.assert_array_equal(first.mean_error, again.mean_error)
    assert first.detection[1, 0] == 1.0
    # Row 1 of the pair is seeded [5, 1, 0], the lone row [5, 0, 0]: different streams.
    assert alone.mean_error[0, 0] != first.mean_error[1, 0]


def test_rendered_wide_camera_against_its_measurements():
    if not MEASURED.exists():
        pytest.skip(
            f"measured camera data {MEASURED} is absent (../shared is not beside the repo)"
        )
    measured = load_measured(MEASURED)
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    distances = (35.0, 40.0, 45.0, 50.0, 55.0, 75.0, 100.0, 150.0, 200.0, 300.0)
    result = sweep(camera, distances, (0.0,), frames=100)
    rows = {row.distance_mm: row for row in compare(result, measured)}
    # 100 frames a point, as `swazure camera calibrate` renders.
    # Issue 17's acceptance, where this model meets it (docs/camera.md gives the whole table):
    # detection within 15 points at every measured distance, the blind limit within 5 mm,
    # the mean error within a factor 1.5 (or 1 point) at 100-200 mm.
    for distance in measured.distances_mm:
        assert rows[float(distance)].detection_ok, rows[float(distance)]
    for distance in (100.0, 150.0, 200.0):
        assert rows[distance].error_ok, rows[distance]
    measured_limit = blind_limit_mm(measured.distances_mm, measured.detect_pct / 100)
    assert abs(blind_limit_mm(result.distances_mm, result.detection[:, 0]) - measured_limit) <= 5.0


def test_decaying_range_ends_where_the_mean_error_runs_wild():
    wild = hand_sweep()
    error = wild.mean_error.copy()
    error[8, 0] = 3.0  # 120 mm: detected, but the mean is 300 % off
    wild = Sweep(
        wild.distances_mm,
        wild.angles_deg,
        100,
        wild.detection,
        error,
        wild.distance_sd,
        wild.direction_sd_deg,
        0.0,
    )
    sensor = sensor_from_sweep(wild, Criteria(decaying_error=1.0))
    assert sensor.decaying_max == 12.0
    assert sensor.relative_error(12.0) == pytest.approx(0.08)


def test_each_range_boundary_is_searched_to_a_millimetre_between_the_sweep_s_points():
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    grid = tuple(np.arange(30.0, 270.0, 12.0))
    result = sweep(camera, grid, (0.0,), frames=20)
    criteria = Criteria()
    on_grid = sensor_from_sweep(result, criteria)
    search = search_ranges(camera, result, on_grid, criteria)
    assert search.renders > 0

    def head_on(distance_mm):
        one = sweep(camera, (distance_mm,), (0.0,), frames=20)
        return float(one.detection[0, 0]), float(one.mean_error[0, 0])

    def sweet(distance_mm):
        detection, error = head_on(distance_mm)
        return detection >= criteria.sweet_detection and abs(error) <= criteria.sweet_error

    def measured(distance_mm):
        detection, error = head_on(distance_mm)
        return detection >= criteria.detection and abs(error) <= criteria.decaying_error

    # Each boundary moved off the grid, by less than one grid step, into a bracket under
    # 1 mm wide whose two ends (rendered again here) hold and fail its criterion.
    for name, holds in (("sweet_min", sweet), ("sweet_max", sweet), ("decaying_max", measured)):
        boundary = 10.0 * getattr(search.sensor, name)
        assert 0 < abs(boundary - 10.0 * getattr(on_grid, name)) < 12.0, name
        inside, outside = search.brackets[name]
        assert abs(outside - inside) <= 1.0, name
        assert min(inside, outside) - 0.05 <= boundary <= max(inside, outside) + 0.05, name
        assert holds(inside) and not holds(outside), name
    assert search.sensor.decaying_min == search.sensor.sweet_max
    assert search.sensor.noise == on_grid.noise
