"""Trajectories: analytic positions and derivatives, and the specs that name them."""

from dataclasses import FrozenInstanceError

import numpy as np
import pytest

from swazure_ros.core.motion import (
    Circle,
    ConstantVelocity,
    Motion,
    TrajectoryError,
    Waypoints,
    trajectory_from_spec,
)


def test_constant_velocity_moves_linearly_from_home_after_zero():
    line = ConstantVelocity(np.array([1.0, -2.0, 0.5]))
    assert np.allclose(line.displacement([-1.0, 0.0, 2.0]), [[0, 0, 0], [0, 0, 0], [2, -4, 1]])
    assert np.allclose(line.velocity([-1.0, 3.0]), [[0, 0, 0], [1, -2, 0.5]])
    assert np.allclose(line.acceleration([3.0]), 0.0)


def test_circle_starts_at_home_and_accelerates_towards_its_centre():
    circle = trajectory_from_spec("circle:2,8")
    assert isinstance(circle, Circle)
    assert np.allclose(circle.displacement(0.0), 0.0)
    assert np.allclose(circle.centre, [-2.0, 0.0, 0.0])
    times = np.linspace(0.0, 8.0, 17)
    offset = circle.displacement(times) - circle.centre
    assert np.allclose(np.linalg.norm(offset, axis=1), 2.0)
    omega = 2 * np.pi / 8
    assert np.allclose(circle.acceleration(times), -(omega**2) * offset)
    assert np.allclose(np.linalg.norm(circle.velocity(times), axis=1), 2.0 * omega)
    # A quarter turn counterclockwise about +z from (0, 0) around (-2, 0).
    assert np.allclose(circle.displacement(2.0), [[-2.0, 2.0, 0.0]])


def test_circle_about_a_tilted_axis_stays_in_its_plane():
    circle = trajectory_from_spec("circle:1,4,0,1,1")
    axis = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    times = np.linspace(0.0, 4.0, 9)
    assert np.allclose(circle.displacement(times) @ axis, 0.0)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("linear:1,2", "expected 3 finite numbers"),
        ("linear:a,b,c", "is not a list of numbers"),
        ("circle:-1,4", "must be positive"),
        ("circle:1,4,0,0,0", "axis must not be zero"),
        ("spiral:1", "unknown trajectory"),
    ],
)
def test_bad_trajectory_specs_raise_one_line_errors(text, message):
    with pytest.raises(TrajectoryError, match=message) as caught:
        trajectory_from_spec(text)
    assert "\n" not in str(caught.value)


def test_motion_moves_only_the_listed_flss_and_gives_relative_truth():
    home = np.array([[0.0, 0, 0], [10.0, 0, 0], [0.0, 10, 0]])
    ids = np.array([3, 5, 9])
    motion = Motion({5: ConstantVelocity(np.array([0.0, 1.0, 0.0]))})
    assert np.allclose(motion.points(home, ids, 2.0), [[0, 0, 0], [10, 2, 0], [0, 10, 0]])
    position, velocity, acceleration = motion.relative(home[2], home[1], 9, 5, [2.0])
    assert np.allclose(position, [[10.0, -8.0, 0.0]])
    assert np.allclose(velocity, [[0.0, 1.0, 0.0]])
    assert np.allclose(acceleration, 0.0)


def test_waypoints_hold_the_spline_through_them_fitted_once():
    there = Waypoints.through([0.0, 2.0, 4.0], [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0]])
    np.testing.assert_allclose(there.spline([0.0, 2.0, 4.0]), there.points, atol=1e-12)
    np.testing.assert_allclose(
        there.displacement([-1.0, 2.0, 9.0])[[0, 2]], [[0, 0, 0], [2, 2, 0]]
    )
    np.testing.assert_allclose(there.velocity([0.0, 4.0, 9.0]), 0.0, atol=1e-12)
    with pytest.raises(FrozenInstanceError):
        there.spline = None  # type: ignore[misc]


@pytest.mark.parametrize(
    ("times", "points", "message"),
    [
        ([0.0], [[0.0, 0.0, 0.0]], "at least two"),
        ([0.0, 0.0], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]], "strictly increasing"),
        ([0.0, 1.0], [[0.0, 0.0], [1.0, 0.0]], "one point"),
    ],
)
def test_waypoints_refuse_times_that_do_not_increase_or_points_that_do_not_fit(
    times, points, message
):
    with pytest.raises(TrajectoryError, match=message):
        Waypoints.through(times, points)
