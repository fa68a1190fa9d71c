"""Estimating a tracked target's motion from relayed samples (spec, section 9).

Each relayed sample is stamped with the time it was sensed and arrives late
(sensing plus communication delay). From the samples the source estimates
the target's velocity and acceleration relative to itself, two ways:

- central differences (:func:`central_differences`), which lag the present by
  the delay plus one (velocity) or two (acceleration) sample intervals;
- a Kalman filter (:class:`KalmanTracker`) with a constant-velocity or
  constant-acceleration model, which predicts the present state from the last
  sample, compensating the known delay.

The filter is filterpy's ``KalmanFilter`` (with ``Q_discrete_white_noise``
for the piecewise white noise models): a maintained, widely used
implementation, so that only the models are ours. Units: s, cm, cm/s, cm/s^2.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .arrays import FloatArray
from .errors import SwazureError

CONSTANT_VELOCITY = "constant-velocity"
CONSTANT_ACCELERATION = "constant-acceleration"
MODELS = (CONSTANT_VELOCITY, CONSTANT_ACCELERATION)


class TrackingError(SwazureError):
    """A track that cannot be set up."""


@dataclass(frozen=True)
class Differences:
    """Central-difference velocity and acceleration, each at its own sample times."""

    velocity_times: FloatArray  # (K - 2,), s
    velocity: FloatArray  # (K - 2, 3), cm/s
    acceleration_times: FloatArray  # (K - 4,), s
    acceleration: FloatArray  # (K - 4, 3), cm/s^2


def _central(times: FloatArray, values: FloatArray) -> tuple[FloatArray, FloatArray]:
    if len(times) < 3:
        return np.zeros(0), np.zeros((0, 3))
    span = (times[2:] - times[:-2])[:, None]
    return times[1:-1], (values[2:] - values[:-2]) / span


def central_differences(times: FloatArray, positions: FloatArray) -> Differences:
    """Spec section 9: v(t_i) = (p_(i+1) - p_(i-1)) / (t_(i+1) - t_(i-1)), a likewise from v.

    With evenly spaced samples the span is the spec's 2 dt. Each estimate
    lags the last sample by one (velocity) or two (acceleration) intervals.

    Parameters
    ----------
    times : (K,) array of float, s
        Sensing times, increasing.
    positions : (K, 3) array of float, cm
        The samples.

    Returns
    -------
    Differences
        Velocity (K - 2, 3), cm/s, at times[1:-1]; acceleration (K - 4, 3),
        cm/s^2, at times[2:-2]; empty arrays when K is too small.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.estimators import central_differences
    >>> times = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    >>> moving = np.column_stack([times**2, 0 * times, 0 * times])  # x = t^2
    >>> found = central_differences(times, moving)
    >>> found.velocity[:, 0].round(9), found.acceleration[:, 0].round(9)
    (array([0.2, 0.4, 0.6]), array([2.]))
    """
    velocity_times, velocity = _central(times, positions)
    acceleration_times, acceleration = _central(velocity_times, velocity)
    return Differences(velocity_times, velocity, acceleration_times, acceleration)


def _transition(order: int, dt: float) -> FloatArray:
    """(3 order, 3 order) state transition over ``dt`` s, state ordered by derivative."""
    single = np.eye(order)
    for power in range(1, order):
        single += np.diag(np.full(order - power, dt**power / math.factorial(power)), power)
    return np.asarray(np.kron(single, np.eye(3)), dtype=np.float64)


@dataclass(frozen=True)
class TrackState:
    """A filter's estimate at one time: position (cm), velocity (cm/s), acceleration (cm/s^2)."""

    time: float
    position: FloatArray  # (3,)
    velocity: FloatArray  # (3,)
    acceleration: FloatArray  # (3,), zero under the constant-velocity model


def check_filter(
    model: str, process_noise: float, measurement_noise: float, initial_speed: float = 10.0
) -> None:
    """TrackingError unless a :class:`KalmanTracker` can be made of these settings.

    Parameters
    ----------
    model : {'constant-velocity', 'constant-acceleration'}
    process_noise : float
        cm/s^2 (constant velocity) or cm/s^3 (constant acceleration), > 0.
    measurement_noise : float, cm
        > 0.
    initial_speed : float, default 10.0, cm/s
        > 0.

    Raises
    ------
    TrackingError
        An unknown model (the message lists the models), or a setting not
        above 0.

    Examples
    --------
    >>> from swazure_ros.core.estimators import check_filter
    >>> check_filter("constant-jerk", 1.0, 0.05)
    Traceback (most recent call last):
    ...
    swazure_ros.core.estimators.TrackingError: unknown model 'constant-jerk': use one of ...
    """
    if model not in MODELS:
        raise TrackingError(f"unknown model {model!r}: use one of {', '.join(MODELS)}")
    if not (process_noise > 0 and measurement_noise > 0 and initial_speed > 0):
        raise TrackingError("process_noise, measurement_noise and initial_speed must be > 0")


class KalmanTracker:
    """A Kalman filter of relative position samples that predicts the present.

    ``process_noise`` is the standard deviation of the white noise that drives
    the model's highest derivative: acceleration (cm/s^2) for the
    constant-velocity model, jerk (cm/s^3) for the constant-acceleration
    model, per second of prediction. ``measurement_noise`` (cm) is that of a
    relayed sample.
    """

    def __init__(
        self,
        model: str = CONSTANT_ACCELERATION,
        process_noise: float = 1.0,
        measurement_noise: float = 0.05,
        initial_speed: float = 10.0,
    ) -> None:
        check_filter(model, process_noise, measurement_noise, initial_speed)
        self.model = model
        self.order = 2 if model == CONSTANT_VELOCITY else 3
        self.process_noise = process_noise
        # Here, not at import: filterpy imports scipy.stats, 0.4 s of an FLS's start.
        from filterpy.kalman import KalmanFilter

        self._filter = KalmanFilter(dim_x=3 * self.order, dim_z=3)
        self._filter.H = np.hstack([np.eye(3), np.zeros((3, 3 * (self.order - 1)))])
        self._filter.R = np.eye(3) * measurement_noise**2
        # Unknown motion at first: the first sample fixes the position only.
        self._filter.P = np.diag(
            np.repeat([measurement_noise**2] + [initial_speed**2] * (self.order - 1), 3)
        )
        self.time: float | None = None

    def _noise(self, dt: float) -> FloatArray:
        from filterpy.common import Q_discrete_white_noise

        return np.asarray(
            Q_discrete_white_noise(
                self.order, dt=dt, var=self.process_noise**2, block_size=3, order_by_dim=False
            )
        )

    def update(self, time: float, position: FloatArray) -> None:
        """Take a sample sensed at ``time`` s: relative position (3,) cm. Samples come in order."""
        if self.time is None:
            self._filter.x = np.concatenate([position, np.zeros(3 * (self.order - 1))])
        else:
            dt = time - self.time
            if dt <= 0:
                raise TrackingError(f"sample at {time} s is not after the last, {self.time} s")
            self._filter.predict(F=_transition(self.order, dt), Q=self._noise(dt))
            self._filter.update(np.asarray(position, dtype=np.float64))
        self.time = time

    def predict(self, time: float) -> TrackState:
        """The state at ``time`` s (the present), extrapolated from the last sample."""
        if self.time is None:
            raise TrackingError("no sample yet")
        state = _transition(self.order, time - self.time) @ self._filter.x
        acceleration = state[6:9] if self.order == 3 else np.zeros(3)
        return TrackState(time, state[0:3], state[3:6], acceleration)
