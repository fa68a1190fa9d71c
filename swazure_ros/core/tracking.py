"""Tracking a moving neighbour out of sight (spec, section 9).

A source FLS that cannot see its target receives the target's relative
position from a relay: an FLS in the source's sweet range that sees the
target. Each sample is stamped with the time it was sensed and arrives late
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
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray
from .errors import SwazureError, UnknownFlsError
from .geometry import tracking_distance
from .hop_errors import measured_vectors
from .motion import Motion
from .sensor import DECAYING, SWEET, Sensor
from .sight import obstructed

CONSTANT_VELOCITY = "constant-velocity"
CONSTANT_ACCELERATION = "constant-acceleration"
MODELS = (CONSTANT_VELOCITY, CONSTANT_ACCELERATION)

# What a relay reports with each sample.
RELAY_OK = 0
RELAY_TARGET_LOST = 1  # the relay's camera no longer sees the target
RELAY_SOURCE_LOST = 2  # the source left the relay's sweet range or view

# The state of a source's stream.
WAITING = "waiting"  # no sample yet
TRACKING = "tracking"
ENDED = "ended"  # the relay said the stream ended
TIMED_OUT = "timed-out"  # the relay went silent for longer than the track allows


class TrackingError(SwazureError):
    """A track that cannot be set up."""


def _seen(
    sensor: Sensor, points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> NDArray[np.int8]:
    """(M,) range class of each second[m] as first[m]'s camera sees it now, or -1 if it cannot."""
    first = np.atleast_1d(np.asarray(first, dtype=np.int64))
    second = np.atleast_1d(np.asarray(second, dtype=np.int64))
    classes = sensor.classify(tracking_distance(points, radius, first, second))
    measurable = (classes == SWEET) | (classes == DECAYING)
    # One line-of-sight query (one grid) for every segment in range.
    blocked = obstructed(points, radius, first[measurable], second[measurable])
    measurable[np.flatnonzero(measurable)[blocked]] = False
    return np.where(measurable, classes, -1).astype(np.int8)


def choose_relay(
    sensor: Sensor, points: FloatArray, radius: float, source: int, target: int
) -> int | None:
    """Index of the relay for source -> target, or None: a sweet neighbour that sees the target.

    Both hops need line of sight. Preferred: a target in the relay's sweet
    range over its decaying range, then the shortest two-hop tracking length
    (to 1e-7 cm, so that symmetric swarms tie whatever the rounding), then
    the lowest index.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, target : int
        Indices into ``points``.

    Returns
    -------
    int or None
        The relay's index; None when no sweet neighbour of the source sees
        the target.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [3, 0, 0], [0, 8, 0], [3, 8.2, 0]])  # cm, r = 0.5
    >>> from swazure_ros.core.tracking import choose_relay
    >>> choose_relay(published, points, 0.5, 0, 1)  # FLS 2: 7 cm from 0, 7.54 cm from 1
    2
    """
    everyone = np.arange(len(points))
    tracking = tracking_distance(points, radius, np.full(len(points), source), everyone)
    candidates = np.flatnonzero(sensor.classify(tracking) == SWEET)
    candidates = candidates[(candidates != source) & (candidates != target)]
    count = len(candidates)
    seen = _seen(
        sensor,
        points,
        radius,
        np.concatenate([np.full(count, source), candidates]),
        np.concatenate([candidates, np.full(count, target)]),
    )
    from_source, to_target = seen[:count], seen[count:]
    usable = (from_source == SWEET) & (to_target >= 0)
    if not usable.any():
        return None
    relays = candidates[usable]
    length = tracking[relays] + tracking_distance(
        points, radius, relays, np.full(len(relays), target)
    )
    # Lengths equal to a nanometre tie, so that symmetric swarms go to the lowest
    # index whatever rounding the distances took. lexsort: last key sorts first.
    order = np.lexsort((relays, np.round(length, 7), to_target[usable] != SWEET))
    return int(relays[order[0]])


def next_relay(
    sensor: Sensor, points: FloatArray, radius: float, source: int, target: int, relay: int
) -> int | None:
    """Index of the relay to hand a stream over to when ``relay`` lost it, or None.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, target, relay : int
        Indices into ``points``.

    Returns
    -------
    int or None
        :func:`choose_relay`'s choice, or None when it is ``relay`` again or
        there is none.
    """
    successor = choose_relay(sensor, points, radius, source, target)
    return None if successor is None or successor == relay else successor


def relay_sample(
    sensor: Sensor, points: FloatArray, radius: float, source: int, relay: int, target: int
) -> tuple[int, FloatArray]:
    """One relayed sample: the hop source -> relay plus relay -> target, cm.

    The relay measures both with its own camera at one instant: the hop is
    minus its measurement of the source, as Swazure sums measured hop vectors.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, relay, target : int
        Indices into ``points``.

    Returns
    -------
    status : int
        RELAY_OK; RELAY_SOURCE_LOST when the source is no longer a sweet
        neighbour in the relay's sight; RELAY_TARGET_LOST when the relay no
        longer sees the target in its sweet or decaying range.
    sample : (3,) array of float, cm
        The target relative to the source; NaN unless RELAY_OK.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [3, 0, 0], [0, 8, 0], [3, 8.2, 0]])  # cm, r = 0.5
    >>> from swazure_ros.core.tracking import relay_sample
    >>> status, sample = relay_sample(published, points, 0.5, 0, 2, 1)
    >>> status, sample.round(2)  # the truth is (3, 0, 0); each hop errs by about 1 %
    (0, array([3.03, 0.  , 0.  ]))
    """
    to_source, to_target = _seen(sensor, points, radius, [relay, relay], [source, target])
    if to_source != SWEET:
        return RELAY_SOURCE_LOST, np.full(3, np.nan)
    if to_target < 0:
        return RELAY_TARGET_LOST, np.full(3, np.nan)
    measured = measured_vectors(sensor, points, radius, [relay, relay], [source, target])
    return RELAY_OK, measured[1] - measured[0]


class RelaySenses:
    """Relay choice and relayed samples by FLS id, with every FLS where it is at a given time.

    ``ids`` (N,) are the FLS ids of the rows of ``positions(seconds)``, which
    gives (N, 3) positions, cm; ``radius`` in cm.
    """

    def __init__(
        self,
        sensor: Sensor,
        radius: float,
        ids: NDArray[np.int64],
        positions: Callable[[float], FloatArray],
    ) -> None:
        self.sensor = sensor
        self.radius = radius
        self.ids = ids
        self.positions = positions

    def row(self, fls_id: int) -> int:
        """Row of FLS ``fls_id``; UnknownFlsError when the swarm has none."""
        row = int(np.searchsorted(self.ids, fls_id))
        if row >= len(self.ids) or self.ids[row] != fls_id:
            raise UnknownFlsError(f"no FLS {fls_id} in this swarm of {len(self.ids)} FLSs")
        return row

    def _fls_id(self, row: int | None) -> int | None:
        return None if row is None else int(self.ids[row])

    def choose_relay(self, source: int, target: int, seconds: float) -> int | None:
        """The relay for ``source`` to track ``target`` at ``seconds`` (:func:`choose_relay`)."""
        points = self.positions(seconds)
        relay = choose_relay(self.sensor, points, self.radius, self.row(source), self.row(target))
        return self._fls_id(relay)

    def next_relay(self, source: int, target: int, relay: int, seconds: float) -> int | None:
        """The relay to hand ``relay``'s stream over to at ``seconds`` (:func:`next_relay`)."""
        points = self.positions(seconds)
        rows = (self.row(source), self.row(target), self.row(relay))
        return self._fls_id(next_relay(self.sensor, points, self.radius, *rows))

    def track_sample(
        self, source: int, relay: int, target: int, seconds: float
    ) -> tuple[int, FloatArray]:
        """(status, (3,) cm) ``relay`` senses for ``source`` at ``seconds``: relay_sample."""
        points = self.positions(seconds)
        rows = (self.row(source), self.row(relay), self.row(target))
        return relay_sample(self.sensor, points, self.radius, *rows)


def moving_senses(
    sensor: Sensor, radius: float, ids: NDArray[np.int64], home: FloatArray, motion: Motion
) -> RelaySenses:
    """Relay senses of FLSs that start at ``home`` and move by ``motion``.

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.
    ids : (N,) array of int
        The FLS ids of the rows of ``home``, sorted.
    home : (N, 3) array of float, cm
        Where each FLS is at t = 0.
    motion : Motion
        Which FLSs move and how; the others stay home.

    Returns
    -------
    RelaySenses
        Relay choice and relayed samples by FLS id, at any time in s.
    """
    return RelaySenses(sensor, radius, ids, lambda seconds: motion.points(home, ids, seconds))


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
    >>> from swazure_ros.core.tracking import central_differences
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
    >>> from swazure_ros.core.tracking import check_filter
    >>> check_filter("constant-jerk", 1.0, 0.05)
    Traceback (most recent call last):
    ...
    swazure_ros.core.tracking.TrackingError: unknown model 'constant-jerk': use one of ...
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


@dataclass(frozen=True)
class MotionEstimate:
    """What a source knows of its target at one present time."""

    status: str  # WAITING, TRACKING, ENDED, TIMED_OUT
    time: float  # the present, s
    sample_time: float  # sensing time of the last sample, s (nan before the first)
    raw: FloatArray  # (3,) last sample, cm
    kalman: TrackState | None  # predicted at ``time`` (delay compensated); None unless TRACKING
    filtered: TrackState | None  # at ``sample_time``: the filter without delay compensation
    difference_velocity: FloatArray  # (3,) at the last central-difference time, cm/s
    difference_acceleration: FloatArray  # (3,), cm/s^2
    message: str = ""
    relay: int = -1  # the FLS relaying the stream


class Track:
    """A source's end of one relayed stream: samples in, estimates of the present out.

    The stream is over when the relay says so and no other relay can take
    over, or when no sample has been sensed for ``timeout`` s: the source
    then stops extrapolating.
    """

    def __init__(self, tracker: KalmanTracker, timeout: float, relay: int = -1) -> None:
        self.tracker = tracker
        self.timeout = timeout
        self.relay = relay
        self.handovers = 0
        self.status = WAITING
        self.message = ""
        # Five samples: the acceleration's central difference spans four intervals.
        self._samples: deque[tuple[float, FloatArray]] = deque(maxlen=5)

    def add(self, time: float, position: FloatArray) -> None:
        """Take a sample sensed at ``time`` s: relative position (3,) cm."""
        if self.status in (ENDED, TIMED_OUT):
            return
        self.tracker.update(time, position)
        self._samples.append((time, np.asarray(position, dtype=np.float64)))
        self.status = TRACKING

    def handover(self, relay: int) -> None:
        """Another relay takes the stream over; the filter keeps its state."""
        self.relay = relay
        self.handovers += 1

    def end(self, message: str) -> None:
        """The relay ended the stream, for the reason ``message``."""
        if self.status not in (ENDED, TIMED_OUT):
            self.status, self.message = ENDED, message

    def check(self, now: float) -> bool:
        """At ``now`` s: time the stream out if it went silent; return True when it just did."""
        last = self._samples[-1][0] if self._samples else None
        if self.status == TRACKING and last is not None and now - last > self.timeout:
            self.status = TIMED_OUT
            self.message = f"no sample for {now - last:.2f} s (timeout {self.timeout:g} s)"
            return True
        return False

    def estimate(self, now: float) -> MotionEstimate:
        """The estimate at the present ``now`` s."""
        nothing = np.full(3, np.nan)
        if not self._samples:
            return MotionEstimate(
                self.status,
                now,
                np.nan,
                nothing,
                None,
                None,
                nothing,
                nothing,
                self.message,
                self.relay,
            )
        times = np.array([sample[0] for sample in self._samples])
        positions = np.array([sample[1] for sample in self._samples])
        differences = central_differences(times, positions)
        velocity = differences.velocity[-1] if len(differences.velocity) else nothing
        acceleration = differences.acceleration[-1] if len(differences.acceleration) else nothing
        tracking = self.status == TRACKING
        return MotionEstimate(
            self.status,
            now,
            float(times[-1]),
            positions[-1],
            self.tracker.predict(now) if tracking else None,
            self.tracker.predict(float(times[-1])) if tracking else None,
            velocity,
            acceleration,
            self.message,
            self.relay,
        )


#: Seconds between a relay's frames, at least: a 1 kHz camera.
MIN_FRAME_PERIOD = 1e-3
#: Seconds of any delay, timeout or run, at most: a day.
MAX_TRACK_SECONDS = 86400.0
#: Frames of one track run, at most (each is a filter step and a message).
MAX_TRACK_FRAMES = 1_000_000


@dataclass(frozen=True)
class TrackConfig:
    """How a track runs: sampling, delays (s), filter and timeout."""

    frame_period: float = 0.1  # s between the relay's camera frames
    sensing_delay: float = 0.0  # s from the frame to the relay's sample
    communication_delay: float = 0.0  # s from the relay to the source
    model: str = CONSTANT_ACCELERATION
    process_noise: float = 10.0  # cm/s^2 (constant velocity) or cm/s^3 (constant acceleration)
    measurement_noise: float = 0.05  # cm
    timeout: float = 1.0  # s without a sample before the stream times out

    @property
    def delay(self) -> float:
        """Total delay from sensing to the source, s."""
        return self.sensing_delay + self.communication_delay

    def __post_init__(self) -> None:
        if not MIN_FRAME_PERIOD <= self.frame_period <= MAX_TRACK_SECONDS:
            raise TrackingError(
                f"frame_period must be {MIN_FRAME_PERIOD:g} to {MAX_TRACK_SECONDS:g} s "
                f"(a camera's frames), got {self.frame_period}"
            )
        if not (
            0 <= self.sensing_delay <= MAX_TRACK_SECONDS
            and 0 <= self.communication_delay <= MAX_TRACK_SECONDS
        ):
            raise TrackingError(f"delays must be 0 to {MAX_TRACK_SECONDS:g} s")
        if not 0 < self.timeout <= MAX_TRACK_SECONDS:
            raise TrackingError(
                f"timeout must be above 0 and at most {MAX_TRACK_SECONDS:g} s, got {self.timeout}"
            )
        check_filter(self.model, self.process_noise, self.measurement_noise)

    def frames(self, duration: float) -> int:
        """Frames a relay takes in ``duration`` s; TrackingError past :data:`MAX_TRACK_FRAMES`."""
        if not 0 < duration <= MAX_TRACK_SECONDS:
            raise TrackingError(f"a duration must be above 0 and at most {MAX_TRACK_SECONDS:g} s")
        frames = math.ceil(duration / self.frame_period)
        if frames > MAX_TRACK_FRAMES:
            raise TrackingError(
                f"{duration:g} s at {self.frame_period:g} s a frame is {frames:,} frames, more "
                f"than {MAX_TRACK_FRAMES:,}: a longer frame_period or a shorter duration"
            )
        return frames

    def tracker(self) -> KalmanTracker:
        """A fresh filter of this configuration."""
        return KalmanTracker(self.model, self.process_noise, self.measurement_noise)


#: TrackConfig's numeric settings -> what they mean: one table for the node
#: parameters (``track.<name>``), the command line and the docs.
TRACK_SETTINGS = {
    "frame_period": "seconds between the relay camera's frames of a tracked target",
    "sensing_delay": "seconds from a frame to the relay's sample",
    "communication_delay": "seconds from the relay to the source",
    "timeout": "seconds without a sample after which a track times out",
    "process_noise": "filter process noise: cm/s^2 (constant velocity), cm/s^3 (acceleration)",
    "measurement_noise": "filter measurement noise of a relayed sample, cm",
}


def nanoseconds(seconds: float) -> int:
    """``seconds`` on the ROS clock's integer nanoseconds.

    Parameters
    ----------
    seconds : float, s

    Returns
    -------
    int, ns
        Rounded to the nearest.
    """
    return round(seconds * 1e9)


def arrival(sensed: float, config: TrackConfig) -> float:
    """When a sample sensed at ``sensed`` s reaches the source, s: the present it is for.

    Added in whole nanoseconds, as the ROS clock adds them.

    Parameters
    ----------
    sensed : float, s
    config : TrackConfig
        Its sensing and communication delays.

    Returns
    -------
    float, s

    Examples
    --------
    >>> from swazure_ros.core.tracking import TrackConfig, arrival
    >>> arrival(0.1, TrackConfig(sensing_delay=0.02, communication_delay=0.03))
    0.15
    """
    # In whole nanoseconds, as the ROS clock adds them.
    return (nanoseconds(sensed) + nanoseconds(config.delay)) / 1e9


RELAY_MESSAGES = {
    RELAY_TARGET_LOST: "the relay lost sight of the target",
    RELAY_SOURCE_LOST: "the source left the relay's sweet range or view",
}


@dataclass(frozen=True)
class TrackRun:
    """One simulated track: the first relay and an estimate per sample (and at the end)."""

    source: int
    target: int
    relay: int
    estimates: list[MotionEstimate]


#: Estimator -> (what it is, the MotionEstimate attribute path) of :func:`track_errors`.
ESTIMATORS = {
    "raw": "the last sample / central differences, as received (no compensation)",
    "filtered": "the Kalman filter at the last sample's time (no compensation)",
    "predicted": "the Kalman filter predicted to the present (delay compensated)",
}


@dataclass(frozen=True)
class TrackSeries:
    """A track's estimates as arrays, (K,) times and (K, 3) vectors, with the truth at each."""

    time: FloatArray  # the present of each estimate, s
    sample_time: FloatArray  # s
    position: dict[str, FloatArray]  # estimator -> (K, 3), cm
    velocity: dict[str, FloatArray]  # cm/s
    acceleration: dict[str, FloatArray]  # cm/s^2
    truth_position: FloatArray  # (K, 3) at ``time``
    truth_velocity: FloatArray
    truth_acceleration: FloatArray


def track_series(
    run: TrackRun, motion: Motion, home_source: FloatArray, home_target: FloatArray
) -> TrackSeries:
    """The TRACKING estimates of ``run`` as arrays, with the true relative motion at each.

    Parameters
    ----------
    run : TrackRun
    motion : Motion
        How the FLSs moved.
    home_source, home_target : (3,) array of float, cm
        The source's and the target's positions at t = 0.

    Returns
    -------
    TrackSeries
        K estimates: per estimator (raw, filtered, predicted) the position
        (K, 3), cm, velocity, cm/s, and acceleration, cm/s^2, and the truth
        at each present.
    """
    tracking = [estimate for estimate in run.estimates if estimate.kalman is not None]
    time = np.array([estimate.time for estimate in tracking])
    truth = motion.relative(home_source, home_target, run.source, run.target, time)

    def stack(values: list[FloatArray]) -> FloatArray:
        return np.array(values, dtype=np.float64).reshape(-1, 3)

    kalman = [estimate.kalman for estimate in tracking]
    filtered = [estimate.filtered for estimate in tracking]
    return TrackSeries(
        time,
        np.array([estimate.sample_time for estimate in tracking]),
        {
            "raw": stack([estimate.raw for estimate in tracking]),
            "filtered": stack([state.position for state in filtered if state]),
            "predicted": stack([state.position for state in kalman if state]),
        },
        {
            "raw": stack([estimate.difference_velocity for estimate in tracking]),
            "filtered": stack([state.velocity for state in filtered if state]),
            "predicted": stack([state.velocity for state in kalman if state]),
        },
        {
            "raw": stack([estimate.difference_acceleration for estimate in tracking]),
            "filtered": stack([state.acceleration for state in filtered if state]),
            "predicted": stack([state.acceleration for state in kalman if state]),
        },
        *truth,
    )


def track_errors(series: TrackSeries, settle: float) -> dict[str, dict[str, tuple[float, float]]]:
    """Quantity -> estimator -> (mean, max) error norm against the truth at the present.

    Only estimates after ``settle`` s count (the filter converging, the
    central differences filling their window); NaN when none does.

    Parameters
    ----------
    series : TrackSeries
    settle : float, s
        Estimates at this time or before are left out.

    Returns
    -------
    dict
        ``errors[quantity][estimator] = (mean, max)``: quantity position
        (cm), velocity (cm/s) or acceleration (cm/s^2); estimator as
        :data:`ESTIMATORS`.
    """
    kept = series.time > settle
    errors: dict[str, dict[str, tuple[float, float]]] = {}
    for quantity, estimates, truth in (
        ("position", series.position, series.truth_position),
        ("velocity", series.velocity, series.truth_velocity),
        ("acceleration", series.acceleration, series.truth_acceleration),
    ):
        errors[quantity] = {}
        for estimator, values in estimates.items():
            norms = np.linalg.norm(values[kept] - truth[kept], axis=1)
            norms = norms[np.isfinite(norms)]
            errors[quantity][estimator] = (
                (float(norms.mean()), float(norms.max())) if len(norms) else (np.nan, np.nan)
            )
    return errors
