"""The sensor abstraction: ranges of the tracking distance and the error model.

A sensor is data (spec, section 3): :class:`Sensor` holds the four range
bounds in cm and the polynomial of the relative error, and
:func:`load_sensor` reads it from a YAML file such as ``config/sensor.yaml``.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import ArrayLike, NDArray

from .errors import SensorError
from .geometry import centre_distance

FloatArray = NDArray[np.float64]

# Range classes of a pair of FLSs, by tracking distance t.
CONTACT = 0  # t <= 0: touching, not a neighbour
BLIND = 1  # 0 < t < sweet_min
SWEET = 2  # sweet_min <= t < sweet_max
DECAYING = 3  # decaying_min <= t < decaying_max
OUT_OF_RANGE = 4  # beyond, or in a gap between the sweet and decaying ranges
RANGE_NAMES = ("contact", "blind", "sweet", "decaying", "out")

SENSOR_FILE_VERSION = 1


@dataclass(frozen=True)
class Sensor:
    """Ranges (cm, of the tracking distance) and relative error polynomial of a sensor."""

    sweet_min: float
    sweet_max: float
    decaying_min: float
    decaying_max: float
    #: Coefficients of the relative error e(t), highest power first; () = error-free.
    error_coefficients: tuple[float, ...] = ()
    name: str = "sensor"

    def __post_init__(self) -> None:
        bounds = (self.sweet_min, self.sweet_max, self.decaying_min, self.decaying_max)
        if not all(math.isfinite(bound) for bound in bounds):
            raise SensorError(f"sensor {self.name}: ranges must be finite numbers, got {bounds}")
        if self.sweet_min < 0:
            raise SensorError(f"sensor {self.name}: sweet_min must be >= 0, got {self.sweet_min}")
        if not self.sweet_min < self.sweet_max <= self.decaying_min < self.decaying_max:
            raise SensorError(
                f"sensor {self.name}: ranges out of order, need "
                f"sweet_min < sweet_max <= decaying_min < decaying_max, got {bounds}"
            )
        if not all(math.isfinite(c) for c in self.error_coefficients):
            raise SensorError(f"sensor {self.name}: error coefficients must be finite")

    @property
    def accurate(self) -> bool:
        """True when the sensor measures without error."""
        return not any(self.error_coefficients)

    def error_free(self) -> Sensor:
        """The same ranges with no measurement error (the 'accurate' mode)."""
        return replace(self, error_coefficients=(), name=f"{self.name} (accurate)")

    def relative_error(self, tracking: ArrayLike) -> FloatArray:
        """Relative error e(t) (a fraction) of tracking distances ``tracking`` (cm)."""
        tracking = np.asarray(tracking, dtype=np.float64)
        if self.accurate:
            return np.zeros_like(tracking)
        return np.asarray(np.polyval(self.error_coefficients, tracking), dtype=np.float64)

    def measured_tracking(self, tracking: ArrayLike) -> FloatArray:
        """Measured tracking distances t (1 + e(t)), cm, for true distances ``tracking``."""
        tracking = np.asarray(tracking, dtype=np.float64)
        return tracking * (1.0 + self.relative_error(tracking))

    def classify(self, tracking: ArrayLike) -> NDArray[np.int8]:
        """Range class (CONTACT, BLIND, SWEET, DECAYING, OUT_OF_RANGE) of each distance, cm."""
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
        return {
            "name": self.name,
            "ranges": {
                "sweet_min": self.sweet_min,
                "sweet_max": self.sweet_max,
                "decaying_min": self.decaying_min,
                "decaying_max": self.decaying_max,
            },
            "error_model": (
                {"kind": "polynomial", "coefficients": list(self.error_coefficients)}
                if not self.accurate
                else {"kind": "none"}
            ),
        }


def _require(mapping: Any, key: str, where: str) -> Any:
    if not isinstance(mapping, dict) or key not in mapping:
        raise SensorError(f"{where}: missing key '{key}'")
    return mapping[key]


def sensor_from_dict(document: Any, where: str = "sensor") -> Sensor:
    """Build a :class:`Sensor` from a parsed sensor YAML document; errors name the key."""
    if not isinstance(document, dict):
        raise SensorError(f"{where}: expected a mapping with 'fileversion' and 'sensor'")
    version = _require(document, "fileversion", where)
    if version != SENSOR_FILE_VERSION:
        raise SensorError(
            f"{where}: fileversion {version!r} is not supported (expected {SENSOR_FILE_VERSION})"
        )
    body = _require(document, "sensor", where)
    ranges = _require(body, "ranges", f"{where}: sensor")
    values: dict[str, float] = {}
    for key in ("sweet_min", "sweet_max", "decaying_min", "decaying_max"):
        value = _require(ranges, key, f"{where}: sensor.ranges")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SensorError(f"{where}: sensor.ranges.{key} must be a number, got {value!r}")
        values[key] = float(value)
    model = body.get("error_model", {"kind": "none"})
    kind = _require(model, "kind", f"{where}: sensor.error_model")
    coefficients: tuple[float, ...] = ()
    if kind == "polynomial":
        raw = _require(model, "coefficients", f"{where}: sensor.error_model")
        if not isinstance(raw, list) or not all(
            isinstance(c, int | float) and not isinstance(c, bool) for c in raw
        ):
            raise SensorError(
                f"{where}: sensor.error_model.coefficients must be a list of numbers"
            )
        coefficients = tuple(float(c) for c in raw)
    elif kind != "none":
        raise SensorError(
            f"{where}: sensor.error_model.kind must be 'polynomial' or 'none', got {kind!r}"
        )
    try:
        return Sensor(**values, error_coefficients=coefficients, name=str(body.get("name", "")))
    except SensorError as err:
        raise SensorError(f"{where}: {err}") from err


def load_sensor(path: str | Path | None = None) -> Sensor:
    """Read a sensor YAML file; ``None`` reads the default, ``config/sensor.yaml``."""
    path = Path(path) if path is not None else default_sensor_path()
    try:
        document = yaml.safe_load(path.read_text())
    except FileNotFoundError as err:
        raise SensorError(f"{path}: no such sensor file") from err
    except OSError as err:
        raise SensorError(f"{path}: cannot read ({err.strerror or err})") from err
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        raise SensorError(f"{path}: not valid YAML{where}") from err
    return sensor_from_dict(document, str(path))


def config_dir() -> Path:
    """The folder of the project's YAML configuration (``config/``)."""
    candidates = []
    if "SWAZURE_CONFIG_DIR" in os.environ:
        candidates.append(Path(os.environ["SWAZURE_CONFIG_DIR"]))
    # A source checkout or editable install, then an installed share/ folder.
    candidates.append(Path(__file__).resolve().parents[2] / "config")
    candidates.append(Path(sys.prefix) / "share" / "swazure_ros" / "config")
    for candidate in candidates:
        if (candidate / "sensor.yaml").is_file():
            return candidate
    raise SensorError("cannot find the configuration folder with sensor.yaml")


def default_sensor_path() -> Path:
    """Path of the default sensor file, ``config/sensor.yaml``."""
    return config_dir() / "sensor.yaml"


def measured_vectors(
    sensor: Sensor, points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> FloatArray:
    """Measured vectors first -> second: true direction, length t' + 2r (spec, section 3).

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array, cm
    radius : float, cm
    first, second : (M,) array_like of int
        The measuring FLS and the measured FLS.

    Returns
    -------
    (M, 3) array, cm
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    offset = points[second] - points[first]
    distance = centre_distance(points, first, second)
    measured = sensor.measured_tracking(distance - 2.0 * radius) + 2.0 * radius
    return np.asarray(offset * (measured / distance)[:, None], dtype=np.float64)
