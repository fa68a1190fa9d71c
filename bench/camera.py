"""The rendering camera: one render-detect-solve by distance, and the calibration sweeps.

The `camera` section of BENCHMARKS.md (`python -m bench --sections camera`).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from bench.common import REPO, SECTIONS_DIR, SHARED, SWAZURE, run_output

CAMERAS = REPO / "config" / "cameras"
MEASURED = SHARED / "datasets" / "aruco-measured" / "rpi-camera-module-3-wide.csv"
#: The distances (mm) of each camera's render-detect-solve timing.
CAMERA_DISTANCES = {"wide": (40, 75, 150, 250), "standard": (80, 150, 300, 450)}


def camera_section(
    args: argparse.Namespace,
    distances: Mapping[str, Sequence[int]] = CAMERA_DISTANCES,
    frames: int = 200,
    tool_options: Sequence[str] = (),
    study_sensors: dict[str, Path] | None = None,
    study_options: Sequence[str] = (),
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The rendering camera: one render-detect-solve by distance, and the calibration sweeps.

    ``tool_options`` narrow `camera calibrate` and `camera patterns`, ``study_options`` the
    studies on the sensors (a smoke test's).
    """
    sys.path.insert(0, str(REPO))
    lines = [
        "## The rendering camera: `swazure camera calibrate`",
        "",
        "One render-detect-solve (the marker's region of the 1280x720 frame; median of 200",
        "frames, random roll), split into rendering and detecting + refining + solving:",
        "",
        "| camera | distance (mm) | region (px) | render (ms) | detect + solve (ms) "
        "| total (ms) |",
        "| --- | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name, some in distances.items():
        lines += [camera_timing_row(name, distance, frames) for distance in some]
    lines += ["", "Calibration sweeps (60 distances x 3 angles x 100 frames, one process):", ""]
    lines += camera_tool_lines(tool_options)
    sensors = CAMERA_STUDY_SENSORS if study_sensors is None else study_sensors
    return [*lines, *camera_study_lines(sensors, study_options, records_dir)]


def camera_timing_row(name: str, distance: int, frames: int) -> str:
    """Median render and detect + solve ms of ``frames`` frames of camera ``name``, one row."""
    import numpy as np

    from swazure_ros.camera.aruco import Detector, MarkerPose, render
    from swazure_ros.files.sensors import load_camera

    camera = load_camera(CAMERAS / f"rpi-camera-module-3-{name}.yaml")
    detector = Detector(camera)
    rng = np.random.default_rng(0)
    rendering, solving, size = [], [], 0
    for _ in range(frames):
        pose = MarkerPose(float(distance), roll_deg=float(rng.uniform(0, 360)))
        started = time.perf_counter()
        frame = render(camera, pose, rng)
        middle = time.perf_counter()
        corners = detector.corners(frame)
        if corners is not None:
            detector.solve(corners)
        rendering.append(middle - started)
        solving.append(time.perf_counter() - middle)
        size = frame.image.shape[0]
    render_ms, solve_ms = 1000 * np.median(rendering), 1000 * np.median(solving)
    return (
        f"| {name} | {distance} | {size} | {render_ms:.2f} | {solve_ms:.2f} "
        f"| {render_ms + solve_ms:.2f} |"
    )


def camera_tool_lines(tool_options: Sequence[str] = ()) -> list[str]:
    """`swazure camera calibrate` of both cameras and `camera patterns`: their outputs."""
    lines = []
    for name in ("wide", "standard"):
        options = ["--measured", str(MEASURED)] if name == "wide" and MEASURED.exists() else []
        wall, peak, code, output = run_output(
            [*SWAZURE, "camera", "calibrate", "--camera",
             str(CAMERAS / f"rpi-camera-module-3-{name}.yaml"), "--quiet", *options,
             *tool_options]
        )  # fmt: skip
        lines += [f"`{name}`: {wall:.1f} s wall, {peak:.0f} MB peak, exit {code}", "", "```"]
        lines += [line for line in output.splitlines() if line.strip()]
        lines += ["```", ""]
    if MEASURED.exists():
        wall, peak, code, output = run_output(
            [*SWAZURE, "camera", "patterns", "--camera",
             str(CAMERAS / "rpi-camera-module-3-wide.yaml"), "--measured", str(MEASURED),
             "--quiet", *tool_options]
        )  # fmt: skip
        lines += [
            "The error by marker pattern (`swazure camera patterns`, the dictionary's 100",
            f"markers, 30 frames a point, head-on): {wall:.1f} s wall, {peak:.0f} MB peak, "
            f"exit {code}",
            "",
            "```",
            *[line for line in output.splitlines() if line.strip()],
            "```",
            "",
        ]
    return lines


CAMERA_STUDY_SENSORS = {
    "published": REPO / "config" / "sensor.yaml",
    "wide, calibrated": REPO / "config" / "cameras" / "sensor-wide-calibrated.yaml",
    "standard, calibrated": REPO / "config" / "cameras" / "sensor-standard-calibrated.yaml",
}


def camera_study_lines(
    sensors: dict[str, Path] = CAMERA_STUDY_SENSORS,
    options: Sequence[str] = (),
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The study on each sensor: plain Swazure's accuracy and the heuristics, beta 0.5."""
    import csv

    tables: dict[str, dict[str, dict[str, dict[str, str]]]] = {}
    lines = [
        "### The study on the calibrated sensors",
        "",
        "`swazure study --sensor FILE --betas 0.5 --policies shortest-length "
        "--heuristic-betas 0.5 --techniques move-obstructing move-source:10` per sensor.",
        "Blind pairs and ranges differ with the sensor's ranges; errors are those of the",
        "estimates of plain Swazure (distance error %, direction error alpha).",
        "",
        "| shape | sensor | blind pairs | sweet % | decaying % | no path % "
        "| distance error % mean | alpha mean (deg) | MO no path % | MS T=10 no path % | wall s |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    walls = {}
    for name, sensor in sensors.items():
        out = records_dir / f"camera-study-{name.split(',')[0]}"
        if out.exists():
            shutil.rmtree(out)
        walls[name], _, code, _ = run_output(
            [*SWAZURE, "study", "--sensor", str(sensor), "--betas", "0.5", "--policies",
             "shortest-length", "--heuristic-betas", "0.5", "--techniques", "move-obstructing",
             "move-source:10", "--out", str(out), "--quiet", *options]
        )  # fmt: skip
        if code != 0:
            lines.append(f"| - | {name} | study failed (exit {code}) | | | | | | | | |")
            continue
        tables[name] = {}
        for kind in ("errors", "paths_move-obstructing", "paths_move-source-T10"):
            with (out / "tables" / f"{kind}.csv").open() as handle:
                tables[name][kind] = {row["shape"]: row for row in csv.DictReader(handle)}
    shapes = next(iter(tables.values()))["errors"] if tables else {}
    for shape in shapes:
        for name, table in tables.items():
            errors = table["errors"][shape]
            mo = table["paths_move-obstructing"][shape]["no_path_pct_beta_0.5"]
            ms = table["paths_move-source-T10"][shape]["no_path_pct_beta_0.5"]
            lines.append(
                f"| {shape} | {name} | {int(errors['blind_pairs']):,} "
                f"| {float(errors['sweet_pct']):.2f} | {float(errors['decaying_pct']):.2f} "
                f"| {float(errors['no_path_pct']):.2f} "
                f"| {float(errors['distance_error_mean_pct']):.3f} "
                f"| {float(errors['alpha_mean_deg']):.3f} | {float(mo):.2f} | {float(ms):.2f} "
                f"| {walls[name]:.0f} |"
            )
    return [*lines, ""]
