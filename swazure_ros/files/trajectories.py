"""Trajectories people give: a spec (``linear:``, ``circle:``) or a waypoint CSV file,
one FLS's (``FLS=TRAJECTORY``) or a swarm's (``;``-separated) (docs/tracking.md)."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..core.motion import (
    TRAJECTORY_KINDS,
    Motion,
    Trajectory,
    TrajectoryError,
    Waypoints,
    comma_numbers,
    trajectory_from_spec,
)
from .reading import TABLE_BYTES, read_text


def read_waypoints(path: str | Path) -> Waypoints:
    """Read a waypoint CSV with header ``t,x,y,z`` (s, and cm from home)."""
    path = Path(path)
    text = read_text(path, "waypoint", TABLE_BYTES, TrajectoryError)
    rows = list(csv.reader(io.StringIO(text, newline="")))
    if not rows or [cell.strip() for cell in rows[0]] != ["t", "x", "y", "z"]:
        raise TrajectoryError(f"{path}: the first line must be the header t,x,y,z")
    values = []
    for number, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        values.append(comma_numbers(",".join(row), f"{path}, line {number}", (4,)))
    if len(values) < 2:
        raise TrajectoryError(f"{path}: needs at least two waypoints")
    table = np.array(values)
    if np.any(np.diff(table[:, 0]) <= 0):
        raise TrajectoryError(f"{path}: waypoint times must increase strictly")
    return Waypoints.through(table[:, 0], table[:, 1:])


def parse_trajectory(text: str) -> Trajectory:
    """A trajectory from ``linear:VX,VY,VZ``, ``circle:RADIUS,PERIOD[,AX,AY,AZ]`` or a CSV path."""
    spec = text.partition(":")[0] in TRAJECTORY_KINDS
    if not spec and (Path(text).suffix.lower() == ".csv" or Path(text).exists()):
        return read_waypoints(text)
    return trajectory_from_spec(text)


def parse_move(text: str) -> tuple[int, Trajectory]:
    """(FLS id, trajectory) of one ``FLS=TRAJECTORY``, e.g. ``0=linear:0,0,0.1``."""
    fls, separator, trajectory = text.partition("=")
    if not separator or not fls.strip().isdigit():
        raise TrajectoryError(f"{text!r}: expected FLS=TRAJECTORY, e.g. 0=linear:0,0,0.1")
    return int(fls), parse_trajectory(trajectory.strip())


def parse_motion(text: str) -> Motion:
    """The Motion of ``FLS=TRAJECTORY`` moves separated by ``;`` ("" : no FLS moves)."""
    return Motion(dict(parse_move(move) for move in text.split(";") if move.strip()))
