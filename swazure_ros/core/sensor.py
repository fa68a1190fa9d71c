"""The sensor abstraction: ranges of the tracking distance and the error model.

A sensor is data (spec, section 3): :class:`Sensor` holds the four range
bounds in cm and the polynomial of the relative error, and
:func:`sensor_from_dict` builds it from the mapping of a sensor file
(:func:`swazure_ros.files.sensors.load_sensor` reads ``config/sensor.yaml``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray
from .draws import standard_normals
from .errors import SensorError
from .geometry import centre_distance

# Range classes of a pair of FLSs, by tracking distance t.
CONTACT = 0  # t <= 0: touching, not a neighbour
BLIND = 1  # 0 < t < sweet_min
SWEET = 2  # sweet_min <= t < sweet_max
DECAYING = 3  # decaying_min <= t < decaying_max
OUT_OF_RANGE = 4  # beyond, or in a gap between the sweet and decaying ranges
RANGE_NAMES = ("contact", "blind", "sweet", "decaying", "out")

SENSOR_FILE_VERSION = 1
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


def _require(mapping: Any, key: str, where: str) -> Any:
    if not isinstance(mapping, dict) or key not in mapping:
        raise SensorError(f"{where}: missing key '{key}'")
    return mapping[key]


def _known_keys(mapping: Any, known: tuple[str, ...], where: str) -> None:
    """SensorError naming the first key of ``mapping`` not in ``known`` (a typo is not ignored)."""
    if not isinstance(mapping, dict):
        raise SensorError(f"{where}: expected a mapping, got {type(mapping).__name__}")
    unknown = [str(key) for key in mapping if key not in known]
    if unknown:
        raise SensorError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(known)})")


#: The keys of each error model kind, besides ``kind``.
_MODEL_KEYS = {
    "none": (),
    "polynomial": ("coefficients",),
    "stochastic": ("noise", "seed"),
    "camera": ("camera", "seed", "markers"),
}


def sensor_from_dict(
    document: Any,
    where: str = "sensor",
    cameras: Callable[[str], PairCamera] | None = None,
) -> Sensor:
    """Build a :class:`Sensor` from a parsed sensor YAML document; errors name the key.

    The layout is ``config/sensor.yaml``'s: ``fileversion`` (1) and ``sensor``
    with ``name``, ``ranges`` (cm) and ``error_model`` (``kind`` none,
    polynomial, stochastic or camera). An unknown key is an error, not ignored.

    Parameters
    ----------
    document : mapping
        The parsed YAML document.
    where : str, default "sensor"
        What the document is (its file name), to start each error's message with.
    cameras : callable, optional
        Reads a ``camera`` kind's camera file by the name the sensor gives it
        (:func:`swazure_ros.files.sensors.load_sensor` reads it beside the
        sensor file); without it a camera sensor is refused.

    Returns
    -------
    Sensor

    Raises
    ------
    SensorError
        A missing or unknown key, another fileversion, a value of the wrong
        kind, ranges out of order, or an error model out of bounds; the
        message names the key.

    Examples
    --------
    >>> from swazure_ros.core.sensor import sensor_from_dict
    >>> ranges = {"sweet_min": 6, "sweet_max": 8, "decaying_min": 8, "decaying_max": 30}
    >>> document = {"fileversion": 1, "sensor": {"name": "camera", "ranges": ranges}}
    >>> sensor_from_dict(document).accurate  # no error_model: error-free
    True
    >>> ranges["sweet_mn"] = 6
    >>> sensor_from_dict(document, "my.yaml")
    Traceback (most recent call last):
    ...
    swazure_ros.core.errors.SensorError: my.yaml: sensor.ranges: unknown key 'sweet_mn' (...)
    """
    if not isinstance(document, dict):
        raise SensorError(f"{where}: expected a mapping with 'fileversion' and 'sensor'")
    version = _require(document, "fileversion", where)
    if version != SENSOR_FILE_VERSION:
        raise SensorError(
            f"{where}: fileversion {version!r} is not supported (expected {SENSOR_FILE_VERSION})"
        )
    _known_keys(document, ("fileversion", "sensor"), where)
    body = _require(document, "sensor", where)
    _known_keys(body, ("name", "ranges", "error_model"), f"{where}: sensor")
    ranges = _require(body, "ranges", f"{where}: sensor")
    _known_keys(
        ranges,
        ("sweet_min", "sweet_max", "decaying_min", "decaying_max"),
        f"{where}: sensor.ranges",
    )
    values: dict[str, float] = {}
    for key in ("sweet_min", "sweet_max", "decaying_min", "decaying_max"):
        value = _require(ranges, key, f"{where}: sensor.ranges")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SensorError(f"{where}: sensor.ranges.{key} must be a number, got {value!r}")
        values[key] = float(value)
    model = body.get("error_model", {"kind": "none"})
    kind = _require(model, "kind", f"{where}: sensor.error_model")
    coefficients: tuple[float, ...] = ()
    noise: SensorNoise | None = None
    if kind == "polynomial":
        raw = _require(model, "coefficients", f"{where}: sensor.error_model")
        if not isinstance(raw, list) or not all(
            isinstance(c, int | float) and not isinstance(c, bool) for c in raw
        ):
            raise SensorError(
                f"{where}: sensor.error_model.coefficients must be a list of numbers"
            )
        coefficients = tuple(float(c) for c in raw)
    elif kind not in ("none", "stochastic", "camera"):
        raise SensorError(
            f"{where}: sensor.error_model.kind must be 'polynomial', 'stochastic', 'camera' "
            f"or 'none', got {kind!r}"
        )
    _known_keys(model, ("kind", *_MODEL_KEYS[kind]), f"{where}: sensor.error_model")
    if kind == "stochastic":
        noise = _noise_from_dict(model, f"{where}: sensor.error_model")
    camera, camera_file, camera_seed = None, "", 0
    markers: tuple[int, ...] = ()
    if kind == "camera":
        camera_file = str(_require(model, "camera", f"{where}: sensor.error_model"))
        camera_seed = model.get("seed", 0)
        if isinstance(camera_seed, bool) or not isinstance(camera_seed, int):
            raise SensorError(f"{where}: sensor.error_model.seed must be an integer")
        if cameras is None:
            raise SensorError(f"{where}: sensor.error_model: no reader for its camera file")
        camera = cameras(camera_file)
        markers = _markers_from(model.get("markers"), camera.dictionary_size, where)
    try:
        return Sensor(
            **values,
            error_coefficients=coefficients,
            name=str(body.get("name", "")),
            noise=noise,
            camera=camera,
            camera_file=camera_file,
            camera_seed=camera_seed,
            camera_markers=markers,
        )
    except SensorError as err:
        raise SensorError(f"{where}: {err}") from err


def _markers_from(raw: Any, dictionary_size: int, where: str) -> tuple[int, ...]:
    """A camera sensor's ``markers``: absent, ``all`` (FLS k carries k mod size) or ids."""
    if raw is None:
        return ()
    if raw == "all":
        return tuple(range(dictionary_size))
    if (
        not isinstance(raw, list)
        or not raw
        or not all(isinstance(m, int) and not isinstance(m, bool) for m in raw)
        or not all(0 <= m < dictionary_size for m in raw)
    ):
        raise SensorError(
            f"{where}: sensor.error_model.markers must be 'all' or a list of marker ids "
            f"from 0 to {dictionary_size - 1}, got {raw!r}"
        )
    return tuple(raw)


def _noise_from_dict(model: Any, where: str) -> SensorNoise:
    table = _require(model, "noise", where)
    _known_keys(
        table,
        ("tracking_cm", "mean_error", "detection", "distance_sd", "direction_sd_deg"),
        f"{where}.noise",
    )
    columns: dict[str, tuple[float, ...]] = {}
    for key in ("tracking_cm", "mean_error", "detection", "distance_sd", "direction_sd_deg"):
        raw = _require(table, key, f"{where}.noise")
        if not isinstance(raw, list) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in raw
        ):
            raise SensorError(f"{where}.noise.{key} must be a list of numbers")
        columns[key] = tuple(float(v) for v in raw)
    seed = model.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise SensorError(f"{where}.seed must be an integer, got {seed!r}")
    try:
        return SensorNoise(**columns, seed=seed)
    except SensorError as err:
        raise SensorError(f"{where}: {err}") from err


def _normal_plane(unit: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors (M, 3) each, normal to ``unit`` (M, 3) and to each other."""
    helper = np.where(np.abs(unit[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    across = np.cross(unit, helper)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    return across, np.cross(unit, across)


def measured_vectors(
    sensor: Sensor, points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> FloatArray:
    """Measured vectors first -> second: true direction, length t' + 2r (spec, section 3).

    A stochastic sensor adds the pair's own seeded draw to the length and the
    direction (the same draw wherever the pair is measured); a rendering
    camera measures the marker in a rendered frame.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array, cm
        FLS centres.
    radius : float, cm
        The FLS radius r.
    first, second : (M,) array_like of int
        The measuring FLS and the measured FLS.

    Returns
    -------
    (M, 3) array, cm
        NaN rows where a camera did not see the marker.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import measured_vectors
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [10, 0, 0]])  # t = 8 cm at r = 1, e(8) = 1.09 %
    >>> measured_vectors(published, points, 1.0, [0], [1]).round(4)
    array([[10.0875,  0.    ,  0.    ]])
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    offset = points[second] - points[first]
    distance = centre_distance(points, first, second)
    tracking = distance - 2.0 * radius
    unit = offset / distance[:, None]
    if sensor.camera is not None:
        # The rendering camera on i's surface aims at j; its frame's x, y, z are
        # (across, other, unit), and it measures the marker's centre on j's surface.
        across, other = _normal_plane(unit)
        centres = sensor.camera.measure_pairs(
            10.0 * tracking,
            sensor.camera_seed,
            first,
            second,
            markers=sensor.camera_markers,
        )
        length = np.linalg.norm(centres, axis=1, keepdims=True)
        seen = centres / length
        direction = seen[:, :1] * across + seen[:, 1:2] * other + seen[:, 2:3] * unit
        return np.asarray(direction * (length / 10.0 + 2.0 * radius), dtype=np.float64)
    measured = sensor.measured_tracking(tracking)
    noise = sensor.noise
    if noise is None:
        return np.asarray(
            offset * ((measured + 2.0 * radius) / distance)[:, None], dtype=np.float64
        )
    # A stochastic sensor: the pair's own draw (fixed by seed and pair) on the
    # length and on the direction, in the plane normal to the true direction.
    z = standard_normals(noise.seed, [first, second], 3)
    measured = measured + tracking * noise.at(noise.distance_sd, tracking) * z[:, 0]
    across, other = _normal_plane(unit)
    spread = np.radians(noise.at(noise.direction_sd_deg, tracking))[:, None]
    direction = unit + spread * (z[:, 1:2] * across + z[:, 2:3] * other)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return np.asarray(direction * (measured + 2.0 * radius)[:, None], dtype=np.float64)


def _hop_deviations(
    sensor: Sensor, tracking: FloatArray, radius: float
) -> tuple[FloatArray, FloatArray]:
    """Standard deviations (cm) of a hop vector's error along the hop and per axis across it.

    Stochastic sensor: the table's scatter of the length, ``t sd_d(t)``, and of
    the direction, ``(t' + 2r) sd_dir(t)`` (small angles). Deterministic
    sensor: its bias ``|t e(t)|`` along the hop and an exact direction.
    """
    noise = sensor.noise
    if noise is None:
        return np.abs(tracking * sensor.relative_error(tracking)), np.zeros_like(tracking)
    length = sensor.measured_tracking(tracking) + 2.0 * radius
    along = tracking * noise.at(noise.distance_sd, tracking)
    return along, length * np.radians(noise.at(noise.direction_sd_deg, tracking))


def hop_error(sensor: Sensor, tracking: ArrayLike, radius: float) -> FloatArray:
    """Expected error that a measured hop adds to a summed vector, per tracking distance (M,).

    The least-error path policy's edge cost (docs/core.md, "Least-error paths"):

    - a deterministic sensor (the published quadratic): the magnitude of the
      hop's length error, ``|t e(t)|``, cm;
    - a stochastic sensor: the variance of the hop vector's error, cm^2: the
      measured length's ``(t sd_d(t))^2`` plus the direction's two axes,
      ``2 ((t' + 2r) sd_dir(t))^2`` (small angles).

    Zero for an error-free sensor. A rendering camera has no model of its
    error but the polynomial its sensor file may give.

    Parameters
    ----------
    sensor : Sensor
    tracking : (M,) array_like of float, cm
        The hops' tracking distances.
    radius : float, cm
        The FLS radius r (the direction's error scales with t' + 2r).

    Returns
    -------
    (M,) array of float
        cm for a deterministic sensor, cm^2 for a stochastic one;
        :func:`expected_error` turns sums of them into cm.

    Examples
    --------
    >>> from swazure_ros.core.sensor import hop_error
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> hop_error(published, [6.0, 7.19, 15.0], 1.0).round(3)  # a 7 cm hop is cheapest
    array([0.092, 0.079, 1.641])
    """
    tracking = np.asarray(tracking, dtype=np.float64)
    along, across = _hop_deviations(sensor, tracking, radius)
    if sensor.noise is None:
        return np.asarray(along, dtype=np.float64)
    return np.asarray(along**2 + 2.0 * across**2, dtype=np.float64)


#: Relative standard deviation (a fraction of the hop's length) that every axis of a
#: hop's covariance has at least: what a model calls exact (the published sensor's
#: direction, a stochastic table's zero scatter) still gets a finite weight in a fit.
COVARIANCE_FLOOR = 1e-5


def unbiased_vectors(sensor: Sensor, vectors: FloatArray, tracking: ArrayLike) -> FloatArray:
    """Measured hop vectors (M, 3), cm, with a stochastic sensor's known bias taken out.

    A calibrated table's mean error e(t) is known: ``t e(t)`` comes off each
    vector's length. The published quadratic is treated as unknown, as the
    paper does: other sensors' vectors come back as they are.

    Parameters
    ----------
    sensor : Sensor
    vectors : (M, 3) array of float, cm
        Measured hop vectors (:func:`measured_vectors`).
    tracking : (M,) array_like of float, cm
        The pairs' true tracking distances, at which e(t) is taken.

    Returns
    -------
    (M, 3) array of float, cm
        ``vectors`` itself for a sensor without a noise table.
    """
    if sensor.noise is None:
        return vectors
    tracking = np.asarray(tracking, dtype=np.float64)
    length = np.linalg.norm(vectors, axis=1)
    corrected = length - tracking * sensor.relative_error(tracking)
    return np.asarray(vectors * (corrected / length)[:, None], dtype=np.float64)


def hop_covariance(
    sensor: Sensor,
    tracking: ArrayLike,
    directions: FloatArray,
    radius: float,
    inverse: bool = False,
) -> FloatArray:
    """Covariance, cm^2, of the error of hops of tracking distance ``tracking``.

    :func:`hop_error`'s two deviations, along the hop (unit ``directions``)
    and across it: ``along^2 u u^T + across^2 (I - u u^T)``; every axis at
    least ``COVARIANCE_FLOOR`` of the hop's length, so that what a model calls
    exact keeps a finite weight in a fit. Taken at the pair's tracking
    distance, as every expected error of the engine is.

    Parameters
    ----------
    sensor : Sensor
    tracking : (M,) array_like of float, cm
        The hops' tracking distances.
    directions : (M, 3) array of float
        The hops' unit directions.
    radius : float, cm
        The FLS radius r.
    inverse : bool, default False
        Give the information matrix (the inverse, cm^-2) instead, built from
        the same two axes: exact where a numerical inverse of a matrix whose
        axes differ by 1e10 is not.

    Returns
    -------
    (M, 3, 3) array of float
        cm^2, or cm^-2 with ``inverse``.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import hop_covariance
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> covariance = hop_covariance(published, [7.0], np.array([[1.0, 0, 0]]), 1.0)[0]
    >>> bool(covariance[0, 0] > 1e5 * covariance[1, 1])  # the bias along, an exact direction
    True
    """
    tracking = np.asarray(tracking, dtype=np.float64)
    along, across = _hop_deviations(sensor, tracking, radius)
    floor = (COVARIANCE_FLOOR * (tracking + 2.0 * radius)) ** 2
    along_var, across_var = along**2 + floor, across**2 + floor
    if inverse:
        along_var, across_var = 1.0 / along_var, 1.0 / across_var
    outer = directions[:, :, None] * directions[:, None, :]
    return np.asarray(
        (along_var - across_var)[:, None, None] * outer + across_var[:, None, None] * np.eye(3),
        dtype=np.float64,
    )


#: Points per cm at which :func:`smallest_hop_error` samples the camera's ranges.
_HOP_ERROR_SAMPLES_PER_CM = 1000
#: How far below the smallest sample :func:`smallest_hop_error` answers (a fraction).
_HOP_ERROR_MARGIN = 1e-2


def smallest_hop_error(sensor: Sensor, radius: float) -> float:
    """A lower bound of :func:`hop_error` over the camera's ranges, sweet_min to decaying_max.

    Sampled every 10 um and at the noise table's rows, then lowered by 1 %:
    both error models are smooth or piecewise linear between the samples, so
    no hop falls below it. Distributed least-error discovery sizes its cost
    buckets by it (protocol.discovery.search.bucket_width).

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.

    Returns
    -------
    float
        In :func:`hop_error`'s unit (cm or cm^2); 0 for an error-free sensor.

    Examples
    --------
    >>> from swazure_ros.core.sensor import smallest_hop_error
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> round(smallest_hop_error(published, 1.0), 4)  # 1 % under e's 0.079 cm at 7.19 cm
    0.0783
    """
    count = int((sensor.decaying_max - sensor.sweet_min) * _HOP_ERROR_SAMPLES_PER_CM) + 2
    samples = np.linspace(sensor.sweet_min, sensor.decaying_max, count)
    if sensor.noise is not None:
        table = np.asarray(sensor.noise.tracking_cm)
        inside = table[(table >= sensor.sweet_min) & (table <= sensor.decaying_max)]
        samples = np.concatenate([samples, inside])
    return float(hop_error(sensor, samples, radius).min() * (1.0 - _HOP_ERROR_MARGIN))


def expected_error(sensor: Sensor, summed: ArrayLike) -> FloatArray:
    """Predicted error (cm) of estimates whose hops' :func:`hop_error` sum to ``summed`` (M,).

    Stochastic sensor: the standard deviation of the summed vector's error,
    ``sqrt(summed)`` (independent hops' variances add). Deterministic sensor:
    ``summed`` itself, which bounds the error (triangle inequality).

    Parameters
    ----------
    sensor : Sensor
    summed : (M,) array_like of float
        Sums of :func:`hop_error` over each estimate's hops (cm, or cm^2 for a
        stochastic sensor).

    Returns
    -------
    (M,) array of float, cm
    """
    summed = np.asarray(summed, dtype=np.float64)
    return np.sqrt(summed) if sensor.noise is not None else summed
