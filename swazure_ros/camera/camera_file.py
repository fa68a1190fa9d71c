"""A camera file (``config/cameras/*.yaml``) as a :class:`~.aruco.Camera`, checked key by key.

:func:`camera_from_dict` takes the parsed document (``files.sensors.load_camera``
reads the file) and refuses, in one line naming the key, what no real camera
has: sizes that are not finite or not positive, a pixel no sensor has, a
marker larger than the image at the closest focus, intrinsics that give no
finite pose (:func:`intrinsics_problem`, the rule a camera driver's
``camera_info`` is held to as well).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import cv2

from ..core.errors import SensorError
from .aruco import Camera, Degradations

#: The camera file's format version (its ``fileversion``).
CAMERA_FILE_VERSION = 1


def _number(
    mapping: Mapping[str, object], key: str, where: str, default: float | None = None
) -> float:
    """``mapping[key]`` (or ``default``) as a finite number; SensorError naming the key."""
    if key not in mapping and default is None:
        raise SensorError(f"{where}: missing key '{key}'")
    value: Any = mapping.get(key, default)
    try:
        # YAML's !!binary gives bytes, which float() parses when they spell a number.
        number = float(value) if not isinstance(value, bool | str | bytes) else math.nan
    except (TypeError, ValueError, OverflowError):  # not a number, or an int beyond any float
        number = math.nan
    if not math.isfinite(number):
        raise SensorError(f"{where}.{key} must be a finite number, got {value!r}")
    return number


def _whole(mapping: Mapping[str, object], key: str, where: str, default: int | None = None) -> int:
    """``mapping[key]`` (or ``default``) as a whole number; SensorError naming the key."""
    value = _number(mapping, key, where, default)
    if value != int(value):
        raise SensorError(f"{where}.{key} must be a whole number, got {value!r}")
    return int(value)


#: Pixels of a camera image's side, at most (an 8K sensor's).
MAX_IMAGE_PX = 8192
#: Focal lengths of a camera's image, px: from a field of view of nearly 180 degrees
#: (1 px across an image of MAX_IMAGE_PX) to a tenth of a degree (1e5 px across 200 px).
#: Beyond, the pose's solve overflows or keeps no digit (fx = fy = 1e-300 gave NaN
#: centres).
FOCAL_PX = (1.0, 1e5)


def intrinsics_problem(fx: float, fy: float, cx: float, cy: float) -> str | None:
    """Why pinhole intrinsics (px) cannot be used, or None.

    Focal lengths ``fx``, ``fy`` from FOCAL_PX[0] to FOCAL_PX[1]; the principal
    point (``cx``, ``cy``) on an image of at most MAX_IMAGE_PX a side. One rule
    for a camera file's and a camera driver's (``camera_info``).
    """
    low, high = FOCAL_PX
    for name, value in (("fx", fx), ("fy", fy)):
        if not low <= value <= high:  # NaN too
            return f"{name} must be {low:g} to {high:g} px, got {value:g}"
    for name, value in (("cx", cx), ("cy", cy)):
        if not 0.0 <= value <= MAX_IMAGE_PX:
            return f"{name} must be 0 to {MAX_IMAGE_PX} px (on the image), got {value:g}"
    return None


def _degradations_from(section: Mapping[str, object], where: str) -> Degradations:
    """The ``camera.degradations`` mapping as :class:`Degradations`; errors name the key."""
    # Every field a finite number, in the record's order; the window then a whole one.
    numbers = {
        key: _number(section, key, f"{where}: camera.degradations")
        for key in Degradations.__dataclass_fields__
        if key != "tone_gamma"
    }
    gamma = Degradations.tone_gamma  # linear, unless the file says otherwise
    if "tone_gamma" in section:
        gamma = _number(section, "tone_gamma", f"{where}: camera.degradations")
        if gamma <= 0:
            raise SensorError(f"{where}: camera.degradations.tone_gamma must be positive")
    del numbers["corner_window_px"]
    window = _whole(section, "corner_window_px", f"{where}: camera.degradations")
    return Degradations(**numbers, tone_gamma=gamma, corner_window_px=window)


def camera_from_dict(document: object, where: str = "camera") -> Camera:
    """Build a :class:`Camera` from a parsed camera YAML document; errors name the key."""
    if not isinstance(document, dict) or document.get("fileversion") != CAMERA_FILE_VERSION:
        raise SensorError(f"{where}: expected a mapping with fileversion {CAMERA_FILE_VERSION}")
    body = document.get("camera")
    if not isinstance(body, dict):
        raise SensorError(f"{where}: missing mapping 'camera'")
    sections = {}
    for key in ("image", "lens", "marker", "degradations"):
        if not isinstance(body.get(key), dict):
            raise SensorError(f"{where}: missing mapping 'camera.{key}'")
        sections[key] = body[key]
    image, lens, marker = sections["image"], sections["lens"], sections["marker"]
    width = _whole(image, "width", f"{where}: camera.image")
    height = _whole(image, "height", f"{where}: camera.image")
    fx = _number(image, "fx", f"{where}: camera.image")
    degradations = _degradations_from(sections["degradations"], where)
    dictionary = str(marker.get("dictionary", "DICT_4X4_100"))
    if not dictionary.startswith("DICT_") or not hasattr(cv2.aruco, dictionary):
        raise SensorError(
            f"{where}: camera.marker.dictionary {dictionary!r} is not an ArUco dictionary"
        )
    camera = Camera(
        name=str(body.get("name", Path(where).stem)),
        width=width,
        height=height,
        fx=fx,
        fy=_number(image, "fy", f"{where}: camera.image", fx),
        cx=_number(image, "cx", f"{where}: camera.image", (width - 1) / 2),
        cy=_number(image, "cy", f"{where}: camera.image", (height - 1) / 2),
        focal_length_mm=_number(lens, "focal_length_mm", f"{where}: camera.lens"),
        f_number=_number(lens, "f_number", f"{where}: camera.lens"),
        focus_min_mm=_number(lens, "focus_min_mm", f"{where}: camera.lens"),
        marker_dictionary=dictionary,
        marker_side_mm=_number(marker, "side_mm", f"{where}: camera.marker"),
        marker_id=_whole(marker, "id", f"{where}: camera.marker", 0),
        degradations=degradations,
    )
    _check_camera(camera, where)
    return camera


def _check_camera(camera: Camera, where: str) -> None:
    """Refuse, in one line naming the key, a camera whose sizes no real camera has."""
    width, height, fx = camera.width, camera.height, camera.fx
    sizes = (width, height, fx, camera.fy, camera.focal_length_mm, camera.f_number)
    if min(*sizes, camera.marker_side_mm, camera.focus_min_mm) <= 0:
        # Each is divided by, or is a scale of the projection.
        raise SensorError(
            f"{where}: sizes, focal lengths (fx, fy, focal_length_mm), the f-number and "
            "focus_min_mm must be positive"
        )
    degradations = camera.degradations
    noise = (degradations.residual_blur_px, degradations.read_noise, degradations.shot_noise_gain)
    if min(noise) < 0:
        raise SensorError(f"{where}: camera.degradations' blur and noise must be 0 or more")
    # Sizes that scale the rendering's kernels and images: a blur or a defocus of
    # millions of px would ask for gigabytes; a marker of kilometres overflows.
    bounded = {
        "camera.marker.side_mm": (camera.marker_side_mm, 0.1, 1000.0),
        "camera.lens.focal_length_mm": (camera.focal_length_mm, 0.1, 1000.0),
        "camera.lens.f_number": (camera.f_number, 0.5, 64.0),
        "camera.lens.focus_min_mm": (camera.focus_min_mm, 1.0, 100_000.0),
        "camera.degradations.residual_blur_px": (degradations.residual_blur_px, 0.0, 50.0),
        "camera.degradations.read_noise": (degradations.read_noise, 0.0, 255.0),
        "camera.degradations.shot_noise_gain": (degradations.shot_noise_gain, 0.0, 255.0),
    }
    for name, (value, low, high) in bounded.items():
        if not low <= value <= high:
            raise SensorError(f"{where}: {name} must be {low:g} to {high:g}, got {value:g}")
    # Derived sizes: a pixel of a real sensor (0.5 to 50 um), and the marker at the
    # closest focus no larger than the image (frames are rendered at that scale).
    pitch_um = 1000.0 * camera.focal_length_mm / camera.fx
    if not 0.5 <= pitch_um <= 50.0:
        raise SensorError(
            f"{where}: focal_length_mm / fx is a pixel of {pitch_um:.3g} um: a sensor's are "
            "0.5 to 50 um"
        )
    marker_px = camera.fx * camera.marker_side_mm / camera.focus_min_mm
    if marker_px > max(width, height):
        raise SensorError(
            f"{where}: the marker at the closest focus is {marker_px:.3g} px across, more than "
            f"the {width}x{height} image"
        )
    levels = (degradations.white_level, degradations.black_level, degradations.background_level)
    if not all(0.0 <= level <= 255.0 for level in levels):
        # Grey levels of an 8-bit frame: the transfer curve takes powers of them.
        raise SensorError(
            f"{where}: camera.degradations' white, black and background levels must be 0 to 255"
        )
    if not 0.1 <= degradations.tone_gamma <= 10.0:
        raise SensorError(f"{where}: camera.degradations.tone_gamma must be 0.1 to 10")
    if max(width, height) > MAX_IMAGE_PX:
        raise SensorError(
            f"{where}: a {width}x{height} image is more than {MAX_IMAGE_PX} px a side"
        )
    window = camera.degradations.corner_window_px
    if not 1 <= window <= min(width, height) // 4:
        raise SensorError(
            f"{where}: camera.degradations.corner_window_px must be 1 to a quarter of the "
            f"image's shorter side ({min(width, height) // 4}), got {window}"
        )
    if not 0 <= camera.marker_id < camera.dictionary_size:
        raise SensorError(
            f"{where}: camera.marker.id {camera.marker_id} is not in {camera.marker_dictionary} "
            f"(0 to {camera.dictionary_size - 1})"
        )
    # Last: the pixel size above bounds fx by the lens already; fy and the principal
    # point only here.
    intrinsics = intrinsics_problem(camera.fx, camera.fy, camera.cx, camera.cy)
    if intrinsics is not None:
        raise SensorError(f"{where}: camera.image: {intrinsics}")
