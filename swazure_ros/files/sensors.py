"""Reading sensor, camera and measured-camera files into the model's objects.

A sensor file (``config/sensor.yaml``) is parsed by
:func:`swazure_ros.core.sensor_file.sensor_from_dict`; a ``camera`` kind names a
camera file (``config/cameras/*.yaml``) beside it, read here.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..core.errors import SensorError
from ..core.sensor import Sensor
from ..core.sensor_file import sensor_from_dict
from .reading import TABLE_BYTES, config_dir, read_text, read_yaml

if TYPE_CHECKING:
    from ..camera.aruco import Camera
    from ..camera.calibration import Measured


def load_sensor(path: str | Path | None = None) -> Sensor:
    """Read a sensor YAML file; ``None`` reads the default, ``config/sensor.yaml``."""
    path = Path(path) if path is not None else default_sensor_path()
    folder = path.parent
    document = read_yaml(path, "sensor", SensorError)
    return sensor_from_dict(document, str(path), lambda name: load_camera(folder / name))


def default_sensor_path() -> Path:
    """Path of the default sensor file, ``config/sensor.yaml``."""
    return config_dir() / "sensor.yaml"


def load_camera(path: str | Path) -> Camera:
    """Read a camera YAML file (``config/cameras/*.yaml``)."""
    # Here, not above: a process that reads a sensor file loads OpenCV only for a camera.
    from ..camera.camera_file import camera_from_dict

    path = Path(path)
    return camera_from_dict(read_yaml(path, "camera", SensorError), str(path))


def load_measured(path: str | Path) -> Measured:
    """Read ``distance_mm,error_pct,detect_pct`` rows (``#`` comments) from a CSV file."""
    from ..camera.calibration import Measured

    path = Path(path)
    text = read_text(path, "measured camera", TABLE_BYTES, SensorError)
    lines = [line for line in text.splitlines() if line and not line.startswith("#")]
    rows = list(csv.DictReader(lines))
    try:
        table = [
            (
                float(r["distance_mm"]),
                float(r["error_pct"]) if r["error_pct"] else math.nan,
                float(r["detect_pct"]),
            )
            for r in rows
        ]
    except (KeyError, TypeError, ValueError) as err:
        raise SensorError(f"{path}: expected columns distance_mm,error_pct,detect_pct") from err
    if not table:
        raise SensorError(f"{path}: no rows")
    values = np.asarray(table, dtype=np.float64)
    return Measured(values[:, 0], values[:, 1], values[:, 2])
