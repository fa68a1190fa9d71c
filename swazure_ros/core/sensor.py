"""The sensor abstraction: ranges of the tracking distance and the error model.

A sensor is data (spec, section 3): :class:`Sensor` holds the four range
bounds in cm and the polynomial of the relative error;
:func:`~.sensor_file.sensor_from_dict` builds it from the mapping of a sensor
file (:func:`swazure_ros.files.sensors.load_sensor` reads ``config/sensor.yaml``),
and :mod:`.hop_errors` measures hops with it and predicts their errors.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from . import jit
from .arrays import FloatArray
from .errors import SensorError

# Range classes of a pair of FLSs, by tracking distance t.
CONTACT = 0  # t <= 0: touching, not a neighbour
BLIND = 1  # 0 < t < sweet_min
SWEET = 2  # sweet_min <= t < sweet_max
DECAYING = 3  # decaying_min <= t < decaying_max
OUT_OF_RANGE = 4  # beyond, or in a gap between the sweet and decaying ranges

#: Distances from which :meth:`Sensor.classify` runs compiled on every core: its five
#: masks took 6 s of the race car at 65,536 FLSs, over every block's and region's
#: candidates; 0.32 s against 0.03 s for 46 M of them (docs/core.md, "Neighbours").
COMPILED_CLASSES = 1 << 20
RANGE_NAMES = ("contact", "blind", "sweet", "decaying", "out")

#: cm of a sensor's reach (decaying_max), at most: every pair within reach is a
#: neighbour, and a camera reading ArUco markers the size of an FLS's sees a metre or two.
MAX_REACH = 1000.0
#: A relative error e(t) above this (1000 %) is no sensor's.
MAX_RELATIVE_ERROR = 10.0
#: Points at which a sensor's relative error is checked across its camera ranges.
_ERROR_CHECK_SAMPLES = 1001


class PairCamera(Protocol):
    """A camera that measures pairs of FLSs (:class:`swazure_ros.camera.aruco.Camera`)."""

    @property
    def marker_id(self) -> int:
        """The marker every FLS carries when a sensor names none."""
        ...

    @property
    def dictionary_size(self) -> int:
        """Markers in the camera's ArUco dictionary."""
        ...

    def measure_pairs(
        self,
        distances_mm: FloatArray,
        seed: int,
        first: NDArray[np.int64],
        second: NDArray[np.int64],
        markers: Sequence[int] = (),
    ) -> FloatArray:
        """Marker centres (M, 3) mm in each measuring camera's frame; NaN rows: not seen."""
        ...


@dataclass(frozen=True)
class SensorNoise:
    """Random part of a stochastic sensor, tabulated by tracking distance (cm), seeded.

    What a calibration (:mod:`.calibration`) writes: per tracking distance the
    mean relative error of a measured distance (the bias, a fraction), the
    probability that a frame detects the marker, the relative standard
    deviation of a measured distance and that of the direction (per axis,
    degrees). Values between table rows are interpolated linearly; beyond
    the table, the end rows hold.
    """

    tracking_cm: tuple[float, ...]
    mean_error: tuple[float, ...]
    detection: tuple[float, ...]
    distance_sd: tuple[float, ...]
    direction_sd_deg: tuple[float, ...]
    seed: int = 0

    def __post_init__(self) -> None:
        columns = (self.detection, self.distance_sd, self.direction_sd_deg)
        if len(self.mean_error) != len(self.tracking_cm):
            raise SensorError("sensor noise: every table column needs one value per tracking_cm")
        if not all(math.isfinite(v) for v in self.mean_error):
            raise SensorError("sensor noise: mean_error values must be finite")
        if not self.tracking_cm or any(len(c) != len(self.tracking_cm) for c in columns):
            raise SensorError("sensor noise: every table column needs one value per tracking_cm")
        if any(b <= a for a, b in zip(self.tracking_cm, self.tracking_cm[1:])):
            raise SensorError("sensor noise: tracking_cm must increase")
        values = [v for c in (self.tracking_cm, *columns) for v in c]
        if not all(math.isfinite(v) for v in values) or min(v for c in columns for v in c) < 0:
            raise SensorError("sensor noise: table values must be finite and >= 0")
        if max(self.detection) > 1:
            raise SensorError("sensor noise: detection is a probability, at most 1")

    def at(self, column: tuple[float, ...], tracking: ArrayLike) -> FloatArray:
        """A table column interpolated at tracking distances ``tracking`` (cm)."""
        return np.interp(np.asarray(tracking, dtype=np.float64), self.tracking_cm, column)

    def to_dict(self) -> dict[str, Any]:
        """The ``noise`` mapping of the sensor YAML."""
        return {
            "tracking_cm": list(self.tracking_cm),
            "mean_error": list(self.mean_error),
            "detection": list(self.detection),
            "distance_sd": list(self.distance_sd),
            "direction_sd_deg": list(self.direction_sd_deg),
        }


@dataclass(frozen=True)
class Sensor:
    """Ranges (cm, of the tracking distance) and relative error polynomial of a sensor.

    The whole of what the model knows about the hardware (spec, section 3):
    blind ``0 < t < sweet_min``, sweet ``sweet_min <= t < sweet_max``, decaying
    ``decaying_min <= t < decaying_max``, out of range beyond. The constructor
    checks the ranges' order and that e(t) stays in (-1, 10] over them, and
    raises :class:`~swazure_ros.core.errors.SensorError` otherwise.

    Examples
    --------
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> published.classify([0.0, 3.0, 7.0, 12.0, 30.0]).tolist()  # contact ... out
    [0, 1, 2, 3, 4]
    >>> published.error_free().accurate
    True
    """

    sweet_min: float
    sweet_max: float
    decaying_min: float
    decaying_max: float
    #: Coefficients of the relative error e(t), highest power first; () = error-free.
    error_coefficients: tuple[float, ...] = ()
    name: str = "sensor"
    #: Random part of a stochastic sensor; None: deterministic (the published model).
    noise: SensorNoise | None = None
    #: A rendering camera that measures every pair (small swarms); None: a model.
    camera: PairCamera | None = None
    #: The camera's file as the sensor file names it, and the seed of its frames.
    camera_file: str = ""
    camera_seed: int = 0
    #: The markers the FLSs carry, FLS k (swarm index) camera_markers[k % len]; () = the
    #: camera file's marker on every FLS.
    camera_markers: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        bounds = (self.sweet_min, self.sweet_max, self.decaying_min, self.decaying_max)
        if not all(math.isfinite(bound) for bound in bounds):
            raise SensorError(f"sensor {self.name}: ranges must be finite numbers, got {bounds}")
        if not self.sweet_min > 0:
            # Blind is 0 < t < sweet_min (spec section 3): a sensor without a blind range has
            # no pair to compute, and the swarm's shortest-length rounds are sweet_min long.
            raise SensorError(
                f"sensor {self.name}: sweet_min must be above 0 (the blind range is "
                f"0 < t < sweet_min), got {self.sweet_min:g}"
            )
        if not self.sweet_min < self.sweet_max <= self.decaying_min < self.decaying_max:
            raise SensorError(
                f"sensor {self.name}: ranges out of order, need "
                f"sweet_min < sweet_max <= decaying_min < decaying_max, got {bounds}"
            )
        if self.decaying_max > MAX_REACH:
            raise SensorError(
                f"sensor {self.name}: decaying_max {self.decaying_max:g} cm is beyond "
                f"{MAX_REACH:g} cm: every FLS that far would be every FLS's neighbour"
            )
        if not all(math.isfinite(c) for c in self.error_coefficients):
            raise SensorError(f"sensor {self.name}: error coefficients must be finite")
        samples = np.linspace(self.sweet_min, self.decaying_max, _ERROR_CHECK_SAMPLES)
        with np.errstate(all="ignore"):
            error = self.relative_error(samples)
        wrong = ~(np.isfinite(error) & (error > -1.0) & (error <= MAX_RELATIVE_ERROR))
        if wrong.any():
            at = float(samples[np.flatnonzero(wrong)[0]])
            raise SensorError(
                f"sensor {self.name}: relative error e({at:g} cm) = {float(error[wrong][0]):.3g}; "
                f"it must stay above -1 (a measured distance above 0) and at most "
                f"{MAX_RELATIVE_ERROR:g} across the camera's ranges"
            )

    @property
    def accurate(self) -> bool:
        """True when the sensor measures without error."""
        return not any(self.error_coefficients) and self.noise is None and self.camera is None

    def error_free(self) -> Sensor:
        """The same ranges with no measurement error (the 'accurate' mode).

        Returns
        -------
        Sensor
            No polynomial, noise table or camera; its name ends "(accurate)".
        """
        return replace(
            self, error_coefficients=(), noise=None, camera=None, name=f"{self.name} (accurate)"
        )

    def relative_error(self, tracking: ArrayLike) -> FloatArray:
        """Relative error e(t) (a fraction) of tracking distances ``tracking`` (cm).

        The polynomial's value, or a stochastic sensor's tabulated mean error
        (its bias); zero for an error-free sensor.

        Parameters
        ----------
        tracking : array_like of float, cm
            Tracking distances, any shape.

        Returns
        -------
        array of float
            e(t), a fraction, of the shape of ``tracking``.

        Examples
        --------
        >>> from swazure_ros.core.sensor import Sensor
        >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
        >>> published.relative_error([6.0, 8.0]).round(4)  # spec: 1.54 %, 1.09 %
        array([0.0154, 0.0109])
        """
        tracking = np.asarray(tracking, dtype=np.float64)
        if self.noise is not None:
            return self.noise.at(self.noise.mean_error, tracking)
        if not any(self.error_coefficients):
            return np.zeros_like(tracking)
        return np.asarray(np.polyval(self.error_coefficients, tracking), dtype=np.float64)

    def measured_tracking(self, tracking: ArrayLike) -> FloatArray:
        """Measured tracking distances t (1 + e(t)), cm, for true distances ``tracking``.

        Parameters
        ----------
        tracking : array_like of float, cm
            True tracking distances, any shape.

        Returns
        -------
        array of float, cm
            Of the shape of ``tracking``.
        """
        tracking = np.asarray(tracking, dtype=np.float64)
        return tracking * (1.0 + self.relative_error(tracking))

    def classify(self, tracking: ArrayLike) -> NDArray[np.int8]:
        """Range class (CONTACT, BLIND, SWEET, DECAYING, OUT_OF_RANGE) of each distance, cm.

        Plain comparisons with no tolerance (spec, section 3): ``t <= 0`` is
        CONTACT, and a gap between sweet_max and decaying_min is OUT_OF_RANGE.

        Parameters
        ----------
        tracking : array_like of float, cm
            Tracking distances, any shape.

        Returns
        -------
        array of int8
            The class of each, of the shape of ``tracking``.
        """
        tracking = np.asarray(tracking, dtype=np.float64)
        if tracking.ndim == 1 and len(tracking) >= COMPILED_CLASSES:
            return _classes(
                tracking, self.sweet_min, self.sweet_max, self.decaying_min, self.decaying_max
            )
        classes = np.full(tracking.shape, OUT_OF_RANGE, dtype=np.int8)
        # Plain comparisons, no tolerance (spec, section 3).
        classes[(tracking >= self.decaying_min) & (tracking < self.decaying_max)] = DECAYING
        classes[(tracking >= self.sweet_min) & (tracking < self.sweet_max)] = SWEET
        classes[(tracking > 0) & (tracking < self.sweet_min)] = BLIND
        classes[tracking <= 0] = CONTACT
        return classes

    def to_dict(self) -> dict[str, Any]:
        """The sensor in the layout of the YAML file's ``sensor`` mapping."""
        if self.camera is not None:
            model: dict[str, Any] = {
                "kind": "camera",
                "camera": self.camera_file,
                "seed": self.camera_seed,
            }
            if self.camera_markers:
                every = tuple(range(self.camera.dictionary_size))
                model["markers"] = (
                    "all" if self.camera_markers == every else list(self.camera_markers)
                )
        elif self.noise is not None:
            model = {
                "kind": "stochastic",
                "seed": self.noise.seed,
                "noise": self.noise.to_dict(),
            }
        elif self.accurate:
            model = {"kind": "none"}
        else:
            model = {"kind": "polynomial", "coefficients": list(self.error_coefficients)}
        return {
            "name": self.name,
            "ranges": {
                "sweet_min": self.sweet_min,
                "sweet_max": self.sweet_max,
                "decaying_min": self.decaying_min,
                "decaying_max": self.decaying_max,
            },
            "error_model": model,
        }


@jit.kernel(cache=True, parallel=True)
def _classes(
    tracking: FloatArray,
    sweet_min: float,
    sweet_max: float,
    decaying_min: float,
    decaying_max: float,
) -> NDArray[np.int8]:
    """:meth:`Sensor.classify` of a long (M,) array, compiled: its masks in its order."""
    classes = np.empty(len(tracking), dtype=np.int8)
    for m in jit.prange(len(tracking)):
        distance = tracking[m]
        # Each later mask overrides the earlier, as classify sets them.
        range_class = OUT_OF_RANGE
        if distance >= decaying_min and distance < decaying_max:
            range_class = DECAYING
        if distance >= sweet_min and distance < sweet_max:
            range_class = SWEET
        if distance > 0 and distance < sweet_min:
            range_class = BLIND
        if distance <= 0:
            range_class = CONTACT
        classes[m] = range_class
    return classes
