"""Trajectories: analytic positions and derivatives, parsing, and the waypoint file."""

import numpy as np
import pytest

from swazure_ros.core.motion import (
    Circle,
    ConstantVelocity,
    Motion,
    TrajectoryError,
    parse_trajectory,
    read_waypoints,
)


def test_constant_velocity_moves_linearly_from_home_after_zero():
    line = ConstantVelocity(np.array([1.0, -2.0, 0.5]))
    assert np.allclose(line.displacement([-1.0, 0.0, 2.0]), [[0, 0, 0], [0, 0, 0], [2, -4, 1]])
    assert np.allclose(line.velocity([-1.0, 3.0]), [[0, 0, 0], [1, -2, 0.5]])
    assert np.allclose(line.acceleration([3.0]), 0.0)


def test_circle_starts_at_home_and_accelerates_towards_its_centre():
    circle = parse_trajectory("circle:2,8")
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
    circle = parse_trajectory("circle:1,4,0,1,1")
    axis = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    times = np.linspace(0.0, 4.0, 9)
    assert np.allclose(circle.displacement(times) @ axis, 0.0)


def test_waypoints_pass_through_their_points_at_rest_at_the_ends(tmp_path):
    path = tmp_path / "path.csv"
    path.write_text("t,x,y,z\n0,0,0,0\n1,1,0,0\n3,1,2,0\n")
    waypoints = parse_trajectory(str(path))
    assert np.allclose(
        waypoints.displacement([0, 1, 3, 5]), [[0, 0, 0], [1, 0, 0], [1, 2, 0], [1, 2, 0]]
    )
    assert np.allclose(waypoints.velocity([0.0, 3.0, 4.0]), 0.0)
    # The spline's derivative is the position's: a finite difference agrees.
    step = 1e-5
    slope = (waypoints.displacement(1.5 + step) - waypoints.displacement(1.5 - step)) / (2 * step)
    assert np.allclose(slope, waypoints.velocity(1.5), atol=1e-6)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("linear:1,2", "expected 3 finite numbers"),
        ("linear:a,b,c", "is not a list of numbers"),
        ("circle:-1,4", "must be positive"),
        ("circle:1,4,0,0,0", "axis must not be zero"),
        ("spiral:1", "unknown trajectory"),
        ("missing.csv", "cannot read waypoints"),
    ],
)
def test_bad_trajectories_raise_one_line_errors(text, message):
    with pytest.raises(TrajectoryError, match=message) as caught:
        parse_trajectory(text)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("time,x,y,z\n0,0,0,0\n1,0,0,0\n", "header"),
        ("t,x,y,z\n0,0,0,0\n", "at least two"),
        ("t,x,y,z\n0,0,0,0\n0,1,0,0\n", "increase strictly"),
        ("t,x,y,z\n0,0,0,0\n1,0,zero,0\n", "line 3"),
    ],
)
def test_bad_waypoint_files_name_the_problem(tmp_path, content, message):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(TrajectoryError, match=message):
        read_waypoints(path)


def test_motion_moves_only_the_listed_flss_and_gives_relative_truth():
    home = np.array([[0.0, 0, 0], [10.0, 0, 0], [0.0, 10, 0]])
    ids = np.array([3, 5, 9])
    motion = Motion({5: ConstantVelocity(np.array([0.0, 1.0, 0.0]))})
    assert np.allclose(motion.points(home, ids, 2.0), [[0, 0, 0], [10, 2, 0], [0, 10, 0]])
    position, velocity, acceleration = motion.relative(home[2], home[1], 9, 5, [2.0])
    assert np.allclose(position, [[10.0, -8.0, 0.0]])
    assert np.allclose(velocity, [[0.0, 1.0, 0.0]])
    assert np.allclose(acceleration, 0.0)
