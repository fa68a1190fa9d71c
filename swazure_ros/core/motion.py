"""Trajectories of moving FLSs: where an FLS is, how fast it goes and accelerates at time t.

Every trajectory starts at the FLS's home point at ``t = 0`` (the point of the
cloud), so that one description fits any FLS. Times are in seconds of the
simulated clock, positions in cm, velocities in cm/s, accelerations in cm/s^2.
Before ``t = 0`` an FLS is at home.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray, IntArray
from .errors import SwazureError

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline


class TrajectoryError(SwazureError):
    """A trajectory description that cannot be followed."""


class Trajectory(Protocol):
    """Displacement from home and its derivatives at times ``t``."""

    def displacement(self, t: ArrayLike) -> FloatArray:
        """(T, 3) displacement from home at times ``t`` (T,), cm."""

    def velocity(self, t: ArrayLike) -> FloatArray:
        """(T, 3) velocity at times ``t`` (T,), cm/s."""

    def acceleration(self, t: ArrayLike) -> FloatArray:
        """(T, 3) acceleration at times ``t`` (T,), cm/s^2."""


def _times(t: ArrayLike) -> FloatArray:
    return np.atleast_1d(np.asarray(t, dtype=np.float64))


@dataclass(frozen=True)
class ConstantVelocity:
    """Straight flight at ``vector`` (3,) cm/s from home, starting at t = 0."""

    vector: FloatArray

    def displacement(self, t: ArrayLike) -> FloatArray:
        """(T, 3) displacement from home, cm."""
        return np.maximum(_times(t), 0.0)[:, None] * self.vector[None, :]

    def velocity(self, t: ArrayLike) -> FloatArray:
        """(T, 3) velocity, cm/s."""
        return np.where((_times(t) >= 0.0)[:, None], self.vector[None, :], 0.0)

    def acceleration(self, t: ArrayLike) -> FloatArray:
        """(T, 3) acceleration, cm/s^2: none."""
        return np.zeros((len(_times(t)), 3))


@dataclass(frozen=True)
class Circle:
    """Uniform circular flight of ``radius`` cm and ``period`` s about ``axis``, from home.

    The centre lies ``radius`` cm from home along ``start`` (a unit vector
    perpendicular to ``axis``, pointing from home to the centre); the FLS turns
    counterclockwise about ``axis``.
    """

    radius: float
    period: float
    axis: FloatArray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    start: FloatArray = field(default_factory=lambda: np.array([-1.0, 0.0, 0.0]))

    @property
    def angular_speed(self) -> float:
        """Angular speed, rad/s."""
        return 2.0 * np.pi / self.period

    @property
    def centre(self) -> FloatArray:
        """(3,) centre of the circle relative to home, cm."""
        return self.radius * self.start

    def _basis(self) -> tuple[FloatArray, FloatArray]:
        outward = -self.start  # from the centre to home
        return outward, np.cross(self.axis, outward)

    def _phase(self, t: ArrayLike) -> FloatArray:
        return self.angular_speed * np.maximum(_times(t), 0.0)

    def displacement(self, t: ArrayLike) -> FloatArray:
        """(T, 3) displacement from home, cm."""
        outward, ahead = self._basis()
        phase = self._phase(t)[:, None]
        return self.centre + self.radius * (np.cos(phase) * outward + np.sin(phase) * ahead)

    def velocity(self, t: ArrayLike) -> FloatArray:
        """(T, 3) velocity, cm/s."""
        outward, ahead = self._basis()
        phase = self._phase(t)[:, None]
        speed = self.radius * self.angular_speed
        moving = (_times(t) >= 0.0)[:, None]
        return moving * speed * (-np.sin(phase) * outward + np.cos(phase) * ahead)

    def acceleration(self, t: ArrayLike) -> FloatArray:
        """(T, 3) acceleration, cm/s^2: towards the centre, radius * angular_speed^2."""
        moving = (_times(t) >= 0.0)[:, None]
        return moving * -(self.angular_speed**2) * (self.displacement(t) - self.centre)


@dataclass(frozen=True)
class Waypoints:
    """Timed waypoints (displacements from home), joined by a clamped cubic spline.

    The FLS is at rest at the first and last waypoint (zero velocity there),
    and holds the first before its time and the last after it. Made by
    :meth:`through`, which checks the times and fits the spline once.
    """

    times: FloatArray  # (K,), s, strictly increasing
    points: FloatArray  # (K, 3), cm
    spline: CubicSpline  # the clamped cubic spline through them, (K, 3) values

    @classmethod
    def through(cls, times: ArrayLike, points: ArrayLike) -> Waypoints:
        """The waypoints ``points`` at ``times``, and the spline through them, fitted once.

        Parameters
        ----------
        times : (K,) array_like of float, s
            Two or more, strictly increasing.
        points : (K, 3) array_like of float, cm
            The displacement from home at each time.

        Returns
        -------
        Waypoints
            The trajectory through them.

        Raises
        ------
        TrajectoryError
            Fewer than two times, times not strictly increasing, or not one
            point (x, y, z) per time.

        Examples
        --------
        >>> from swazure_ros.core.motion import Waypoints
        >>> there = Waypoints.through([0.0, 2.0], [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
        >>> there.displacement([1.0, 5.0]).tolist()
        [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]
        """
        times = np.asarray(times, dtype=np.float64)
        points = np.asarray(points, dtype=np.float64)
        if times.ndim != 1 or len(times) < 2 or np.any(np.diff(times) <= 0):
            raise TrajectoryError("waypoint times must be at least two, strictly increasing")
        if points.shape != (len(times), 3):
            raise TrajectoryError(
                f"waypoints need one point (x, y, z) per time: {len(times)} times, "
                f"points of shape {points.shape}"
            )
        from scipy.interpolate import (
            CubicSpline,  # here, not at import: an FLS alone never calls it
        )

        return cls(times, points, CubicSpline(times, points, bc_type="clamped"))

    def _eval(self, t: ArrayLike, order: int) -> FloatArray:
        times = _times(t)
        inside = (times >= self.times[0]) & (times <= self.times[-1])
        clipped = np.clip(times, self.times[0], self.times[-1])
        values = np.asarray(self.spline(clipped, order), dtype=np.float64)
        return values if order == 0 else values * inside[:, None]

    def displacement(self, t: ArrayLike) -> FloatArray:
        """(T, 3) displacement from home, cm."""
        return self._eval(t, 0)

    def velocity(self, t: ArrayLike) -> FloatArray:
        """(T, 3) velocity, cm/s."""
        return self._eval(t, 1)

    def acceleration(self, t: ArrayLike) -> FloatArray:
        """(T, 3) acceleration, cm/s^2."""
        return self._eval(t, 2)


@dataclass(frozen=True)
class Motion:
    """Which FLSs move and how: FLS id -> trajectory; every other FLS stays home."""

    trajectories: Mapping[int, Trajectory] = field(default_factory=dict)

    def points(self, home: FloatArray, ids: IntArray, t: float) -> FloatArray:
        """(N, 3) positions (cm) at ``t`` s of the FLSs ``ids`` (N,) whose homes are ``home``."""
        points = home.copy()
        if not self.trajectories:
            return points
        index = np.searchsorted(ids, list(self.trajectories))
        for row, trajectory in zip(index, self.trajectories.values(), strict=True):
            points[row] += trajectory.displacement(t)[0]
        return points

    def _state(self, fls_id: int, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        trajectory = self.trajectories.get(fls_id)
        if trajectory is None:
            zeros = np.zeros((len(t), 3))
            return zeros, zeros, zeros
        return trajectory.displacement(t), trajectory.velocity(t), trajectory.acceleration(t)

    def relative(
        self,
        home_source: FloatArray,
        home_target: FloatArray,
        source: int,
        target: int,
        t: ArrayLike,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """True position (cm), velocity (cm/s), acceleration (cm/s^2) of target - source, (T,3)"""
        times = _times(t)
        target_state = self._state(target, times)
        source_state = self._state(source, times)
        position = (home_target - home_source) + target_state[0] - source_state[0]
        return position, target_state[1] - source_state[1], target_state[2] - source_state[2]


def comma_numbers(text: str, what: str, counts: tuple[int, ...]) -> list[float]:
    """The ``counts`` finite numbers of comma-separated ``text``; errors say ``what``.

    Parameters
    ----------
    text : str
        E.g. ``"1,2.5,3"``.
    what : str
        What the numbers are, to start the error's message with.
    counts : tuple of int
        How many numbers may be given.

    Returns
    -------
    list of float

    Raises
    ------
    TrajectoryError
        A part that is no number, a count not in ``counts``, NaN or inf.

    Examples
    --------
    >>> from swazure_ros.core.motion import comma_numbers
    >>> comma_numbers("1,2.5,3", "velocity", (3,))
    [1.0, 2.5, 3.0]
    """
    try:
        numbers = [float(part) for part in text.split(",")] if text else []
    except ValueError:
        raise TrajectoryError(f"{what}: {text!r} is not a list of numbers") from None
    if len(numbers) not in counts or not np.all(np.isfinite(numbers)):
        wanted = " or ".join(str(count) for count in counts)
        raise TrajectoryError(f"{what}: expected {wanted} finite numbers, got {text!r}")
    return numbers


def _perpendicular(axis: FloatArray) -> FloatArray:
    # The basis vector least aligned with the axis (the first on ties), made perpendicular.
    basis = np.eye(3)[int(np.argmin(np.abs(axis)))]
    perpendicular = basis - basis.dot(axis) * axis
    return np.asarray(perpendicular / np.linalg.norm(perpendicular), dtype=np.float64)


#: The trajectories a spec names (``KIND:NUMBERS``); a waypoint file is read in files/.
TRAJECTORY_KINDS = ("linear", "circle")


def trajectory_from_spec(text: str) -> Trajectory:
    """A trajectory from ``linear:VX,VY,VZ`` or ``circle:RADIUS,PERIOD[,AX,AY,AZ]``.

    Parameters
    ----------
    text : str
        ``linear:VX,VY,VZ``, a velocity in cm/s; or ``circle:RADIUS,PERIOD``
        in cm and s, about the z axis or the axis AX,AY,AZ (any length),
        counterclockwise, starting at home.

    Returns
    -------
    Trajectory
        :class:`ConstantVelocity` or :class:`Circle`.

    Raises
    ------
    TrajectoryError
        An unknown kind, numbers that are not numbers or not as many as the
        kind takes, a radius or period not above 0, or a zero axis.

    Examples
    --------
    >>> from swazure_ros.core.motion import trajectory_from_spec
    >>> trajectory_from_spec("linear:1,0,0").displacement([2.0])  # cm after 2 s
    array([[2., 0., 0.]])
    >>> trajectory_from_spec("circle:2,4").displacement([1.0, 2.0]).round(9)  # a quarter, a half
    array([[-2.,  2.,  0.],
           [-4.,  0.,  0.]])
    """
    kind, _, arguments = text.partition(":")
    if kind == "linear":
        return ConstantVelocity(np.array(comma_numbers(arguments, "linear", (3,))))
    if kind == "circle":
        numbers = comma_numbers(arguments, "circle (RADIUS,PERIOD[,AX,AY,AZ])", (2, 5))
        radius, period = numbers[:2]
        if radius <= 0 or period <= 0:
            raise TrajectoryError(f"circle: radius and period must be positive, got {arguments!r}")
        axis = np.array(numbers[2:] if len(numbers) == 5 else [0.0, 0.0, 1.0])
        if not np.linalg.norm(axis) > 0:
            raise TrajectoryError("circle: the axis must not be zero")
        axis = axis / np.linalg.norm(axis)
        return Circle(radius, period, axis, -_perpendicular(axis))
    raise TrajectoryError(
        f"unknown trajectory {text!r}: use linear:VX,VY,VZ, circle:RADIUS,PERIOD[,AX,AY,AZ] "
        "or a waypoint CSV file (t,x,y,z)"
    )
