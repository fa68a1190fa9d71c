"""The sensor file's mapping, checked key by key, as a :class:`~.sensor.Sensor`.

:func:`sensor_from_dict` reads the layout of ``config/sensor.yaml``
(:func:`swazure_ros.files.sensors.load_sensor` parses the YAML); every error
names the key.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from .errors import SensorError
from .sensor import PairCamera, Sensor, SensorNoise

SENSOR_FILE_VERSION = 1


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
    >>> from swazure_ros.core.sensor_file import sensor_from_dict
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
