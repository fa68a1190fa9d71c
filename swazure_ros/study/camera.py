"""Figures of a camera calibration: error and detection against distance, and a contact sheet."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..camera.aruco import Camera, MarkerPose, render
from ..camera.calibration import MarkerSweep, Measured, Sweep
from ..core.sensor import Sensor
from ..view.png import save


def calibration_figure(
    result: Sweep, sensor: Sensor, camera: Camera, measured: Measured | None = None
) -> Figure:
    """Mean distance error and detection rate against distance, per angle, measured beside."""
    figure = Figure(figsize=(11.0, 4.4), layout="constrained")
    error_axes, detection_axes = figure.subplots(1, 2)
    figure.suptitle(
        f"{camera.name}: rendered, detected and solved ({result.frames} frames a point)"
    )
    for column, angle in enumerate(result.angles_deg):
        label = f"rendered, {angle:g}°"
        # A mean over a few lucky frames says little: drawn where most frames detect.
        error = np.where(result.detection[:, column] >= 0.5, result.mean_error[:, column], np.nan)
        error_axes.plot(result.distances_mm, 100.0 * error, ".-", label=label)
        detection_axes.plot(
            result.distances_mm, 100.0 * result.detection[:, column], ".-", label=label
        )
    if measured is not None:
        error_axes.plot(measured.distances_mm, measured.error_pct, "ks", label="measured")
        detection_axes.plot(measured.distances_mm, measured.detect_pct, "ks", label="measured")
    curve = np.linspace(sensor.sweet_min, sensor.decaying_max, 100)
    error_axes.plot(
        10.0 * curve, 100.0 * sensor.relative_error(curve), "k--", lw=1, label="calibrated sensor"
    )
    for ax in (error_axes, detection_axes):
        for bound, _name in (
            (sensor.sweet_min, "sweet"),
            (sensor.sweet_max, ""),
            (sensor.decaying_max, "out"),
        ):
            ax.axvline(10.0 * bound, color="grey", lw=0.8, ls=":")
        ax.axvspan(0, 10.0 * sensor.sweet_min, color="grey", alpha=0.12)
        ax.set_xlabel("distance camera to marker (mm) = tracking distance")
        ax.grid(True, alpha=0.3)
        ax.set_xlim(0, float(result.distances_mm[-1]) + 10)
    error_axes.set_ylabel("error of the mean measured distance (%)")
    error_axes.set_title("distance error (shaded: blind)")
    top = np.nanmax(np.abs(100.0 * np.where(result.detection >= 0.5, result.mean_error, np.nan)))
    if measured is not None:
        top = max(top, float(np.nanmax(measured.error_pct)))
    error_axes.set_ylim(-5, min(max(top * 1.15, 5.0), 120.0))
    detection_axes.set_ylabel("frames with a detection (%)")
    detection_axes.set_title("detection rate")
    detection_axes.set_ylim(-3, 103)
    error_axes.legend(loc="upper left", fontsize=8)
    detection_axes.legend(loc="lower right", fontsize=8)
    return figure


def pattern_figure(
    result: MarkerSweep, camera: Camera, measured: Measured | None = None
) -> Figure:
    """Mean distance error against distance, one line per marker, the camera's own marker bold."""
    figure = Figure(figsize=(7.5, 4.6), layout="constrained")
    axes = figure.subplots()
    figure.suptitle(
        f"{camera.name}: the error by marker pattern\n"
        f"{len(result.marker_ids)} markers of {camera.marker_dictionary}, "
        f"{result.frames} frames a point, head-on",
        fontsize=10,
    )
    # Magnitudes, on a log axis: a marker's error spans two decades over the distances.
    error = 100.0 * np.abs(result.reliable_error)
    for row in range(len(result.marker_ids)):
        axes.plot(result.distances_mm, error[row], color="tab:blue", lw=0.6, alpha=0.25)
    axes.plot([], [], color="tab:blue", lw=0.6, alpha=0.5, label="one marker")
    axes.plot(result.distances_mm, np.nanmedian(error, axis=0), "b-", lw=2, label="median")
    own = int(np.flatnonzero(result.marker_ids == camera.marker_id)[0])
    axes.plot(
        result.distances_mm, error[own], "r.-", lw=1.5, label=f"id {camera.marker_id} (the file's)"
    )
    if measured is not None:
        axes.plot(measured.distances_mm, measured.error_pct, "ks", label="measured")
        top = float(np.nanmax(measured.error_pct))
    else:
        top = 0.0
    axes.set_yscale("log")
    axes.set_ylim(0.1, max(top, float(np.nanmax(error))) * 1.5)
    axes.set_xlabel("distance camera to marker (mm)")
    axes.set_ylabel("|error of the mean measured distance| (%)")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(loc="upper left", fontsize=8)
    return figure


def contact_sheet(
    camera: Camera, distances_mm: Sequence[float], angles_deg: Sequence[float], seed: int = 0
) -> Figure:
    """Rendered frames (the marker's region, at its pixels) for each distance and angle."""
    rows, columns = len(angles_deg), len(distances_mm)
    figure = Figure(figsize=(1.9 * columns, 2.1 * rows), layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False)
    figure.suptitle(f"{camera.name}: rendered frames (grey levels as recorded)")
    for row, angle in enumerate(angles_deg):
        for column, distance in enumerate(distances_mm):
            rng = np.random.default_rng([seed, row, column])
            frame = render(
                camera, MarkerPose(float(distance), tilt_deg=float(angle), roll_deg=20.0), rng
            )
            ax = axes[row, column]
            ax.imshow(frame.image, cmap="gray", vmin=0, vmax=255, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            ax.set_title(
                f"{distance:g} mm, {angle:g}°\n{frame.image.shape[1]}x{frame.image.shape[0]} px",
                fontsize=8,
            )
    return figure


def save_figure(figure: Figure, path: Path) -> Path:
    """Write a camera figure as PNG, atomically."""
    return save(figure, path)
