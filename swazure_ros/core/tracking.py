"""Tracking a moving neighbour out of sight (spec, section 9): the source's track.

A source FLS receives the target's relative position from a relay
(:mod:`.relay`), each sample late by the sensing and communication delays,
and estimates the target's motion from the samples (:mod:`.estimators`).
Here: the source's end of one stream (:class:`Track`), how a track runs
(:class:`TrackConfig`), and a run's estimates against the truth
(:func:`track_series`, :func:`track_errors`). Units: s, cm, cm/s, cm/s^2.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .arrays import FloatArray
from .estimators import (
    CONSTANT_ACCELERATION,
    KalmanTracker,
    TrackingError,
    TrackState,
    central_differences,
    check_filter,
)
from .motion import Motion

# The state of a source's stream.
WAITING = "waiting"  # no sample yet
TRACKING = "tracking"
ENDED = "ended"  # the relay said the stream ended
TIMED_OUT = "timed-out"  # the relay went silent for longer than the track allows


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
