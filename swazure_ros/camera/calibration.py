"""Calibrating a sensor from a rendering camera: sweep, ranges, error curve, noise.

:func:`sweep` renders, detects and solves many frames per distance and
viewing angle with :mod:`.aruco`; :func:`sensor_from_sweep` turns the
head-on part of the sweep into the sensor abstraction of :mod:`swazure_ros.core.sensor`
(ranges, the error polynomial, and the stochastic noise tables), by the
criteria of :class:`Criteria`. :func:`compare` sets a sweep beside a measured
camera's table (``datasets/aruco-measured``); :func:`marker_sweep` repeats
the head-on sweep for each marker of the dictionary.

Distances of the camera are in mm; the sensor's tracking distances in cm
(the camera on one FLS's surface, the marker on the other's: the camera's
distance is the tracking distance).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..core.arrays import FloatArray, IntArray
from ..core.errors import SensorError
from ..core.sensor import Sensor, SensorNoise
from .aruco import Camera, Detector, MarkerPose, measure, true_centre

#: Default angles of a sweep: head-on and two slants, degrees.
DEFAULT_ANGLES_DEG = (0.0, 30.0, 60.0)
#: A marker smaller than this many pixels a side is below ArucoDetector's
#: default perimeter limit (3 % of 1280 px), so the default sweep stops there.
SMALLEST_MARKER_PX = 9.0


def default_distances(camera: Camera, count: int = 60) -> tuple[float, ...]:
    """Sweep distances, mm: from 0.6 of the closest focus to where the marker is too small."""
    near = 0.6 * camera.focus_min_mm
    far = camera.fx * camera.marker_side_mm / SMALLEST_MARKER_PX
    return tuple(float(d) for d in np.round(np.linspace(near, far, count), 1))


@dataclass(frozen=True)
class Criteria:
    """How the sensor's ranges follow from the sweep (fractions)."""

    #: Blind below, out of range beyond: where fewer frames than this detect the marker.
    detection: float = 0.5
    #: Sweet range: at least this many detections and a mean error at most sweet_error.
    sweet_detection: float = 0.95
    sweet_error: float = 0.02
    #: Out of range, too, where the mean error passes this (the published e(30) is 0.918).
    decaying_error: float = 1.0


@dataclass(frozen=True)
class Sweep:
    """Per distance (rows) and angle (columns): what the rendered camera measured."""

    distances_mm: FloatArray  # (D,)
    angles_deg: FloatArray  # (A,)
    frames: int
    detection: FloatArray  # (D, A) fraction of frames with a detection
    #: Relative error of the mean measured distance, (D, A); nan with no detection.
    mean_error: FloatArray
    distance_sd: FloatArray  # (D, A) relative sd of a measured distance
    direction_sd_deg: FloatArray  # (D, A) sd of the direction's angle per axis, degrees
    seconds_per_frame: float


def sweep(
    camera: Camera,
    distances_mm: Sequence[float] | None = None,
    angles_deg: Sequence[float] = DEFAULT_ANGLES_DEG,
    frames: int = 100,
    seed: int = 0,
    on_progress: Callable[[int, int], None] | None = None,
    markers: Sequence[int] = (),
) -> Sweep:
    """Render ``frames`` frames at each distance and angle: random roll and sub-pixel place.

    ``distances_mm`` defaults to :func:`default_distances`; each point has its
    own random stream (seed, row, column), so a point's numbers do not
    depend on the rest of the sweep. With ``markers`` frame k of a point
    shows ``markers[k % len]`` (a swarm whose FLSs carry those markers), not
    the camera file's marker.
    """
    import time

    if distances_mm is None:
        distances_mm = default_distances(camera)
    shown = [replace(camera, marker_id=int(m)) for m in markers] or [camera]
    detectors = [Detector(one) for one in shown]
    shape = (len(distances_mm), len(angles_deg))
    detection, mean_error, distance_sd, direction_sd = (np.full(shape, np.nan) for _ in range(4))
    started = time.perf_counter()
    for row, distance in enumerate(distances_mm):
        for column, angle in enumerate(angles_deg):
            rng = np.random.default_rng([seed, row, column])
            ratios, tangents = [], []
            for frame in range(frames):
                pose = MarkerPose(
                    float(distance),
                    tilt_deg=float(angle),
                    roll_deg=float(rng.uniform(0.0, 360.0)),
                    offset_px=(float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5))),
                )
                which = frame % len(shown)
                centre = measure(shown[which], pose, rng, detectors[which])
                if centre is None:
                    continue
                truth = true_centre(camera, pose)
                ratios.append(np.linalg.norm(centre) / np.linalg.norm(truth))
                unit = centre / np.linalg.norm(centre)
                truth_unit = truth / np.linalg.norm(truth)
                tangents.append(unit[:2] - truth_unit[:2])
            detection[row, column] = len(ratios) / frames
            if ratios:
                mean_error[row, column] = float(np.mean(ratios)) - 1.0
                distance_sd[row, column] = float(np.std(ratios))
                direction_sd[row, column] = math.degrees(float(np.std(np.asarray(tangents))))
        if on_progress is not None:
            on_progress(row + 1, len(distances_mm))
    elapsed = time.perf_counter() - started
    return Sweep(
        np.asarray(distances_mm, dtype=np.float64),
        np.asarray(angles_deg, dtype=np.float64),
        frames,
        detection,
        mean_error,
        distance_sd,
        direction_sd,
        elapsed / max(1, frames * shape[0] * shape[1]),
    )


@dataclass(frozen=True)
class MarkerSweep:
    """Head-on, per marker of the dictionary (rows) and distance (columns)."""

    marker_ids: IntArray  # (M,)
    distances_mm: FloatArray  # (D,)
    frames: int
    detection: FloatArray  # (M, D) fraction of frames with a detection
    mean_error: FloatArray  # (M, D) relative error of the mean measured distance; nan if none

    @property
    def reliable_error(self) -> FloatArray:
        """``mean_error`` (M, D) where at least half the frames detect, else nan.

        A mean over a few lucky frames says little.
        """
        return np.where(self.detection >= 0.5, self.mean_error, np.nan)

    def least_error(self) -> tuple[IntArray, FloatArray]:
        """Marker ids and their mean |error| over the distances, least first (ties by id).

        A distance counts for a marker where its error is reliable; a marker
        reliable at none of them comes last.
        """
        reliable = np.abs(self.reliable_error)
        counted = np.isfinite(reliable).sum(axis=1)
        score = np.where(counted > 0, np.nansum(reliable, axis=1) / np.maximum(counted, 1), np.inf)
        order = np.lexsort((self.marker_ids, score))
        return self.marker_ids[order], score[order]


def pattern_distances(camera: Camera, measured: Measured | None = None) -> tuple[float, ...]:
    """Distances of :func:`marker_sweep`, mm: 13 from the closest focus to 4 times it.

    With ``measured``, also its distances where the measured camera detected
    in at least half its frames.
    """
    grid = {round(float(d), 1) for d in np.linspace(1.0, 4.0, 13) * camera.focus_min_mm}
    if measured is not None:
        grid |= {float(d) for d, p in zip(measured.distances_mm, measured.detect_pct) if p >= 50.0}
    return tuple(sorted(grid))


def marker_sweep(
    camera: Camera,
    distances_mm: Sequence[float],
    marker_ids: Sequence[int],
    frames: int = 30,
    seed: int = 0,
    on_progress: Callable[[int, int], None] | None = None,
) -> MarkerSweep:
    """:func:`sweep` head-on for each of ``marker_ids`` in place of the camera's own marker.

    Beyond the distance where the corner window reaches the marker's inner
    edges, the bits next to its corners pull the refined corners, so the
    error there belongs to the pattern as much as to the camera.
    """
    detection = np.full((len(marker_ids), len(distances_mm)), np.nan)
    mean_error = np.full_like(detection, np.nan)
    for row, marker in enumerate(marker_ids):
        result = sweep(camera, distances_mm, (0.0,), frames, seed, markers=(int(marker),))
        detection[row], mean_error[row] = result.detection[:, 0], result.mean_error[:, 0]
        if on_progress is not None:
            on_progress(row + 1, len(marker_ids))
    return MarkerSweep(
        np.asarray(marker_ids, dtype=np.int64),
        np.asarray(distances_mm, dtype=np.float64),
        frames,
        detection,
        mean_error,
    )


def crossing(distances: FloatArray, rate: FloatArray, level: float, rising: bool) -> float:
    """First distance where ``rate`` crosses ``level`` (rising or falling), interpolated."""
    above = rate >= level
    for index in range(1, distances.size):
        if (rising and above[index] and not above[index - 1]) or (
            not rising and above[index - 1] and not above[index]
        ):
            low, high = rate[index - 1], rate[index]
            share = (level - low) / (high - low)
            return float(distances[index - 1] + share * (distances[index] - distances[index - 1]))
    return math.nan


def sensor_from_sweep(
    result: Sweep, criteria: Criteria = Criteria(), name: str = "calibrated", seed: int = 0
) -> Sensor:
    """The sensor abstraction (cm) from the head-on column of a sweep.

    Blind below the first distance where detection rises to ``criteria.detection``;
    sweet from the first distance meeting the sweet criteria up to the first
    that does not; decaying from there until detection falls below
    ``criteria.detection`` or the mean error passes ``criteria.decaying_error``
    (a corner window wider than a far marker makes wild means). The error
    model is the sweep's table per tracking distance (mean error, detection,
    scatter), not a polynomial: a camera's
    error is flat, then grows steeply, which a quadratic smooths into
    negative errors at the near end. Where the camera detects nothing the
    mean error of the nearest detected distance holds.
    """
    column = int(np.argmin(np.abs(result.angles_deg)))
    distances = result.distances_mm
    detection = result.detection[:, column]
    error = result.mean_error[:, column]
    blind_limit = crossing(distances, detection, criteria.detection, rising=True)
    if detection[0] >= criteria.detection:
        blind_limit = float(distances[0])
    far_limit = crossing(distances, detection, criteria.detection, rising=False)
    if math.isnan(blind_limit):
        raise SensorError("calibration: the camera never detects the marker in the sweep")
    if math.isnan(far_limit):
        far_limit = float(distances[-1])
    sweet = (detection >= criteria.sweet_detection) & (np.abs(error) <= criteria.sweet_error)
    sweet &= distances >= blind_limit
    if not sweet.any():
        raise SensorError(
            "calibration: no distance meets the sweet criteria "
            f"(detection >= {criteria.sweet_detection}, error <= {criteria.sweet_error})"
        )
    first = int(np.argmax(sweet))
    last = first
    while last + 1 < sweet.size and sweet[last + 1]:
        last += 1
    sweet_min = max(float(distances[first]), blind_limit)
    sweet_max = float(distances[last + 1]) if last + 1 < distances.size else float(distances[last])
    wild = (distances >= sweet_max) & ~(
        np.abs(np.nan_to_num(error, nan=0.0)) <= criteria.decaying_error
    )
    if wild.any():
        far_limit = min(far_limit, float(distances[int(np.argmax(wild))]))
    decaying_max = max(far_limit, sweet_max + 1e-3)
    tracking_cm = distances / 10.0
    # Only distances most frames detect say what the camera's error is.
    reliable = (detection >= criteria.detection) & (np.abs(error) <= criteria.decaying_error)
    reliable &= distances <= far_limit
    mean_error = np.interp(tracking_cm, tracking_cm[reliable], error[reliable])
    noise = SensorNoise(
        tracking_cm=tuple(float(t) for t in tracking_cm),
        mean_error=tuple(float(e) for e in mean_error),
        detection=tuple(float(p) for p in detection),
        distance_sd=tuple(
            float(s) if math.isfinite(s) else 0.0 for s in result.distance_sd[:, column]
        ),
        direction_sd_deg=tuple(
            float(s) if math.isfinite(s) else 0.0 for s in result.direction_sd_deg[:, column]
        ),
        seed=seed,
    )
    return Sensor(
        sweet_min=round(sweet_min / 10.0, 4),
        sweet_max=round(sweet_max / 10.0, 4),
        decaying_min=round(sweet_max / 10.0, 4),
        decaying_max=round(decaying_max / 10.0, 4),
        name=name,
        noise=noise,
    )


#: How closely :func:`search_ranges` places each range boundary, mm.
BOUNDARY_TOLERANCE_MM = 1.0


@dataclass(frozen=True)
class RangeSearch:
    """The sensor with its boundaries searched, and how: per boundary the last two
    distances rendered, mm (where its criterion held, where it did not)."""

    sensor: Sensor
    renders: int  # distances rendered besides the sweep
    brackets: dict[str, tuple[float, float]]  # sweet_min, sweet_max, decaying_max


def search_ranges(
    camera: Camera,
    result: Sweep,
    sensor: Sensor,
    criteria: Criteria = Criteria(),
    seed: int = 0,
    markers: Sequence[int] = (),
    tolerance_mm: float = BOUNDARY_TOLERANCE_MM,
) -> RangeSearch:
    """``sensor`` with sweet_min, sweet_max and decaying_max placed by their criteria to 1 mm.

    :func:`sensor_from_sweep` puts a boundary at a point of the sweep's grid
    (1.2 cm apart by default). Each boundary lies between two grid points
    where its criterion flips; bisection between them, rendering head-on
    frames (``result.frames``) at each midpoint, narrows that to
    ``tolerance_mm`` and takes the middle (to 0.1 mm). A boundary at the
    grid's ends stays where it is.
    """
    distances = result.distances_mm
    renders = 0

    def head_on(distance: float) -> tuple[float, float]:
        nonlocal renders
        renders += 1
        one = sweep(camera, (distance,), (0.0,), result.frames, seed, markers=markers)
        return float(one.detection[0, 0]), float(one.mean_error[0, 0])

    def sweet(distance: float) -> bool:
        detection, error = head_on(distance)
        return detection >= criteria.sweet_detection and abs(error) <= criteria.sweet_error

    def measured(distance: float) -> bool:
        detection, error = head_on(distance)
        return detection >= criteria.detection and not abs(error) > criteria.decaying_error

    def bracket(boundary_mm: float) -> tuple[float, float] | None:
        """The grid points below and at (or above) a boundary; None at the grid's ends."""
        above = int(np.searchsorted(distances, boundary_mm - 1e-6))
        if above == 0 or above >= len(distances):
            return None
        return float(distances[above - 1]), float(distances[above])

    brackets: dict[str, tuple[float, float]] = {}

    def search(name: str, inside_below: bool, holds: Callable[[float], bool]) -> float:
        boundary_cm = float(getattr(sensor, name))
        limits = bracket(10.0 * boundary_cm)
        if limits is None:
            return boundary_cm
        inside, outside = limits if inside_below else limits[::-1]
        while abs(outside - inside) > tolerance_mm:
            middle = (inside + outside) / 2.0
            if holds(middle):
                inside = middle
            else:
                outside = middle
        brackets[name] = (inside, outside)
        return round((inside + outside) / 20.0, 2)

    sweet_min = search("sweet_min", False, sweet)
    sweet_max = search("sweet_max", True, sweet)
    decaying_max = max(search("decaying_max", True, measured), sweet_max + 0.01)
    searched = replace(
        sensor,
        sweet_min=min(sweet_min, sweet_max - 0.01),
        sweet_max=sweet_max,
        decaying_min=sweet_max,
        decaying_max=decaying_max,
    )
    return RangeSearch(searched, renders, brackets)


@dataclass(frozen=True)
class Measured:
    """A measured camera's table: per distance, error of the mean distance and detection rate."""

    distances_mm: FloatArray
    error_pct: FloatArray  # nan where too few detections to measure
    detect_pct: FloatArray


@dataclass(frozen=True)
class FitRow:
    """One measured distance beside the rendered camera at the same distance (head-on)."""

    distance_mm: float
    measured_error_pct: float
    rendered_error_pct: float
    measured_detect_pct: float
    rendered_detect_pct: float

    @property
    def detection_ok(self) -> bool:
        """Detection rate within 15 points."""
        return abs(self.rendered_detect_pct - self.measured_detect_pct) <= 15.0

    @property
    def error_ok(self) -> bool | None:
        """Mean error within a factor 1.5 or 1 point; None where either is not measured."""
        measured, rendered = self.measured_error_pct, abs(self.rendered_error_pct)
        if not (math.isfinite(measured) and math.isfinite(rendered)):
            return None
        return abs(rendered - measured) <= 1.0 or measured / 1.5 <= rendered <= measured * 1.5


def compare(result: Sweep, measured: Measured) -> list[FitRow]:
    """The head-on sweep at each measured distance (interpolated between sweep points)."""
    column = int(np.argmin(np.abs(result.angles_deg)))
    distances = result.distances_mm
    error = result.mean_error[:, column]
    known = np.isfinite(error)
    rows = []
    for distance, error_pct, detect_pct in zip(
        measured.distances_mm, measured.error_pct, measured.detect_pct, strict=True
    ):
        detect = float(np.interp(distance, distances, result.detection[:, column]))
        nearest = int(np.argmin(np.abs(distances - distance)))
        rendered_error = (
            float(np.interp(distance, distances[known], error[known])) * 100.0
            if known[nearest]
            else math.nan
        )
        rows.append(
            FitRow(
                float(distance),
                float(error_pct),
                rendered_error,
                float(detect_pct),
                detect * 100.0,
            )
        )
    return rows


def blind_limit_mm(
    distances_mm: FloatArray, detect_fraction: FloatArray, level: float = 0.5
) -> float:
    """Where detection first rises to ``level`` with distance, mm (interpolated)."""
    return crossing(
        np.asarray(distances_mm, np.float64), np.asarray(detect_fraction, np.float64), level, True
    )


def fit_score(rows: Sequence[FitRow]) -> float:
    """How far a rendered camera is from the measured one: squared differences, scaled.

    Detection rates in units of the 15-point tolerance; errors as log ratios in
    units of log 1.5 (differences under 1 point count as none, as in the
    acceptance of issue 17), where the measured camera detected the marker in
    at least half its frames (elsewhere its mean rests on a few frames).
    """
    score = 0.0
    for row in rows:
        score += ((row.rendered_detect_pct - row.measured_detect_pct) / 15.0) ** 2
        measured, rendered = row.measured_error_pct, abs(row.rendered_error_pct)
        reliable = row.measured_detect_pct >= 50.0 and math.isfinite(measured)
        if reliable and not math.isfinite(rendered):
            score += 25.0
        elif reliable and abs(rendered - measured) > 1.0:
            score += (math.log(max(rendered, 0.1) / max(measured, 0.1)) / math.log(1.5)) ** 2
    return score


def fit_degradations(
    camera: Camera,
    measured: Measured,
    grid: dict[str, Sequence[float]],
    frames: int = 60,
    seed: int = 0,
    on_progress: Callable[[int, int], None] | None = None,
) -> list[tuple[dict[str, float], float, list[FitRow]]]:
    """Every combination of ``grid`` (degradation -> values), best first by :func:`fit_score`."""
    import itertools

    names = list(grid)
    combos = list(itertools.product(*(grid[name] for name in names)))
    ranked = []
    for index, values in enumerate(combos):
        setting: dict[str, Any] = dict(zip(names, values, strict=True))
        if "corner_window_px" in setting:
            setting["corner_window_px"] = int(setting["corner_window_px"])
        candidate = replace(camera, degradations=replace(camera.degradations, **setting))
        result = sweep(candidate, tuple(measured.distances_mm), (0.0,), frames, seed)
        rows = compare(result, measured)
        ranked.append((setting, fit_score(rows), rows))
        if on_progress is not None:
            on_progress(index + 1, len(combos))
    ranked.sort(key=lambda item: item[1])
    return ranked
