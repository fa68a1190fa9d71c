"""Trajectories people give: specs, waypoint files, and one FLS's or a swarm's moves."""

import numpy as np
import pytest

from swazure_ros.core.motion import ConstantVelocity, TrajectoryError, Waypoints
from swazure_ros.files.trajectories import parse_motion, parse_trajectory, read_waypoints


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
        # A spec's own errors are core's (test/core/test_motion.py); these are the dispatch's.
        ("linear:1,2", "expected 3 finite numbers"),
        ("spiral:1", "unknown trajectory"),
        ("missing.csv", "missing.csv: no such waypoint file"),
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


def test_a_spec_is_a_spec_and_a_path_is_a_waypoint_file(tmp_path):
    path = tmp_path / "path.csv"
    path.write_text("t,x,y,z\n0,0,0,0\n1,1,0,0\n")
    assert isinstance(parse_trajectory("linear:0,0,1"), ConstantVelocity)
    assert isinstance(parse_trajectory(str(path)), Waypoints)


def test_a_swarm_s_moves_name_their_flss():
    motion = parse_motion("0=linear:0,0,1; 2=circle:1,4")
    assert np.allclose(
        motion.points(np.zeros((3, 3)), np.arange(3), 1.0)[[0, 1]], [[0, 0, 1], [0, 0, 0]]
    )
    with pytest.raises(TrajectoryError, match="expected FLS=TRAJECTORY"):
        parse_motion("linear:0,0,1")
