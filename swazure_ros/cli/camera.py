"""Calibrate a sensor from a rendering ArUco camera (render, detect, solve with OpenCV).

``swazure camera calibrate --camera FILE`` sweeps distance and viewing angle,
renders many frames per point, and writes a sensor YAML (ranges, error
polynomial, noise tables) that every other verb reads with --sensor.
``swazure camera fit`` searches the degradations (blur, noise, corner
window) that best match a measured camera's table.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import yaml

from ..camera.aruco import Camera
from ..camera.calibration import (
    BOUNDARY_TOLERANCE_MM,
    DEFAULT_ANGLES_DEG,
    SMALLEST_MARKER_PX,
    Criteria,
    FitRow,
    Measured,
    Sweep,
    blind_limit_mm,
    compare,
    fit_degradations,
    marker_sweep,
    pattern_distances,
    search_ranges,
    sensor_from_sweep,
    sweep,
)
from ..core.errors import SensorError
from ..core.sensor import Sensor
from ..core.sensor_file import SENSOR_FILE_VERSION
from ..files.atomic import atomic_write
from ..files.sensors import load_camera, load_measured
from .arguments import (
    count,
    distance_mm,
    input_file,
    output_file,
    png_file,
    seed,
    viewing_angle,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Subcommands of ``swazure camera``."""
    actions = parser.add_subparsers(
        dest="action", metavar="ACTION", required=True, parser_class=type(parser)
    )
    calibrate = actions.add_parser(
        "calibrate", help="sweep distance and angle; write a sensor YAML"
    )
    _common(calibrate)
    calibrate.add_argument(
        "--out", type=output_file, metavar="FILE", help="write the sensor YAML here"
    )
    calibrate.add_argument(
        "--plot", type=png_file, metavar="FILE.png", help="error and detection against distance"
    )
    calibrate.add_argument(
        "--sheet", type=png_file, metavar="FILE.png", help="contact sheet of rendered frames"
    )
    calibrate.add_argument(
        "--all-markers",
        action="store_true",
        help="show the dictionary's markers in turn, frame by frame (a swarm whose FLSs "
        "carry them all), not the camera file's one",
    )
    calibrate.add_argument(
        "--angles",
        type=viewing_angle,
        nargs="+",
        default=list(DEFAULT_ANGLES_DEG),
        metavar="DEG",
        help="viewing angles of the sweep, degrees (default 0 30 60)",
    )
    patterns = actions.add_parser(
        "patterns", help="the error head-on for every marker of the dictionary"
    )
    _common(patterns, frames=30)
    patterns.add_argument(
        "--distances",
        type=distance_mm,
        nargs="+",
        metavar="MM",
        help="distances, mm (default: 13 from the closest focus to 4 times it, and the "
        "measured ones where the measured camera detected)",
    )
    patterns.add_argument(
        "--plot", type=png_file, metavar="FILE.png", help="error against distance per marker"
    )
    fit = actions.add_parser("fit", help="search the degradations that match a measured camera")
    _common(fit)
    fit.add_argument("--top", type=count, default=5, help="how many of the best settings to print")


def _common(parser: argparse.ArgumentParser, frames: int = 100) -> None:
    parser.add_argument(
        "--camera",
        type=input_file,
        required=True,
        metavar="FILE",
        help="camera YAML (config/cameras/)",
    )
    parser.add_argument(
        "--measured",
        type=input_file,
        metavar="CSV",
        help="a measured camera's table (distance_mm,error_pct,detect_pct) to compare with",
    )
    parser.add_argument(
        "--frames",
        type=count,
        default=frames,
        help=f"frames per distance and angle (default {frames})",
    )
    parser.add_argument(
        "--seed", type=seed, default=0, help="seed of the frames' noise, roll and placement"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress on stderr")


def _progress(quiet: bool, what: str) -> Callable[[int, int], None]:
    started = time.monotonic()

    def report(done: int, total: int) -> None:
        if (not quiet and sys.stderr.isatty()) or (not quiet and done == total):
            print(
                f"\r{what}: {done}/{total} ({time.monotonic() - started:.0f} s)",
                end="",
                file=sys.stderr,
            )
            if done == total:
                print(file=sys.stderr)

    return report


def _written(path: Path, write: Callable[[], object]) -> None:
    """Run ``write``; a file that cannot be written is one line of error, not a traceback."""
    try:
        write()
    except OSError as err:
        raise SensorError(f"{path}: cannot write ({err.strerror or err})") from err


def sheet_distances(camera: Camera) -> tuple[float, ...]:
    """Distances of the contact sheet, mm: around the closest focus, then out to the far end."""
    far = camera.fx * camera.marker_side_mm / (1.5 * SMALLEST_MARKER_PX)
    near = tuple(round(camera.focus_min_mm * f) for f in (0.7, 0.9, 1.2, 2.0))
    return (*near, round((2.0 * camera.focus_min_mm + far) / 2), round(far))


def main(args: argparse.Namespace) -> int:
    """Run ``swazure camera ACTION``."""
    if args.action == "calibrate" and 0.0 not in args.angles:
        raise SensorError("--angles must include 0: the sensor's ranges come from head-on frames")
    camera = load_camera(args.camera)
    measured = load_measured(args.measured) if args.measured else None
    if args.action == "fit":
        return _fit(args, camera, measured)
    if args.action == "patterns":
        return _patterns(args, camera, measured)
    markers = tuple(range(camera.dictionary_size)) if args.all_markers else ()
    result = sweep(
        camera,
        angles_deg=tuple(args.angles),
        frames=args.frames,
        seed=args.seed,
        on_progress=_progress(args.quiet, "sweep"),
        markers=markers,
    )
    criteria = Criteria()
    on_grid = sensor_from_sweep(result, criteria, name=f"{camera.name}-calibrated", seed=args.seed)
    searched = search_ranges(camera, result, on_grid, criteria, args.seed, markers)
    sensor, renders = searched.sensor, searched.renders
    shown = (
        f"the {len(markers)} markers of {camera.marker_dictionary} in turn"
        if markers
        else f"marker {camera.marker_id}"
    )
    print(
        f"camera {camera.name} ({shown}): {result.frames} frames at each of "
        f"{result.distances_mm.size} distances "
        f"x {result.angles_deg.size} angles, {1000 * result.seconds_per_frame:.2f} ms a frame"
    )
    column = int(abs(result.angles_deg).argmin())
    print(
        f"blind limit (detection < {criteria.detection:.0%}): "
        f"{blind_limit_mm(result.distances_mm, result.detection[:, column]):.1f} mm"
    )
    print(
        f"ranges (tracking distance, cm): blind < {sensor.sweet_min:g} "
        f"<= sweet < {sensor.sweet_max:g} "
        f"<= decaying < {sensor.decaying_max:g} "
        f"(each boundary searched to {BOUNDARY_TOLERANCE_MM:g} mm between the sweep's points: "
        f"{renders} more distances rendered; on the sweep's grid "
        f"{on_grid.sweet_min:g}, {on_grid.sweet_max:g}, {on_grid.decaying_max:g})"
    )
    at = (
        sensor.sweet_min,
        sensor.sweet_max,
        (sensor.decaying_min + sensor.decaying_max) / 2,
        sensor.decaying_max,
    )
    print(
        "mean error: "
        + ", ".join(f"e({t:g}) = {100 * float(sensor.relative_error(t)):.2f} %" for t in at)
    )
    if measured is not None:
        # Rendered at the measured distances themselves, head-on, not read off
        # the sweep's grid: the error rises steeply between grid points.
        at_measured = sweep(
            camera,
            tuple(measured.distances_mm),
            (0.0,),
            frames=args.frames,
            seed=args.seed,
            markers=markers,
        )
        _print_fit(compare(at_measured, measured), measured, result, column)
    if args.out:
        _write_sensor(args, sensor, markers)
    if args.plot or args.sheet:
        _draw_figures(args, camera, result, sensor, measured)
    return 0


def _write_sensor(args: argparse.Namespace, sensor: Sensor, markers: tuple[int, ...]) -> None:
    """Write the calibrated ``sensor`` to --out, with the command that made it."""
    document = {"fileversion": SENSOR_FILE_VERSION, "sensor": sensor.to_dict()}
    header = (
        f"# Written by `swazure camera calibrate --camera {args.camera} "
        f"--frames {args.frames} "
        + ("--all-markers " if markers else "")
        + f"--seed {args.seed}`.\n# Stochastic sensor: ranges by docs/camera.md's criteria; "
        "per tracking "
        "distance (cm) the mean error, detection and scatter.\n"
    )
    text = header + yaml.safe_dump(document, sort_keys=False, width=100)
    _written(args.out, lambda: atomic_write(args.out, lambda tmp: tmp.write_text(text)))
    print(f"wrote {args.out}")


def _draw_figures(
    args: argparse.Namespace,
    camera: Camera,
    result: Sweep,
    sensor: Sensor,
    measured: Measured | None,
) -> None:
    """Draw the calibration figure (--plot) and the contact sheet (--sheet)."""
    from ..study.camera import calibration_figure, contact_sheet, save_figure

    if args.plot:
        figure = calibration_figure(result, sensor, camera, measured)
        _written(args.plot, lambda: save_figure(figure, args.plot))
        print(f"wrote {args.plot}")
    if args.sheet:
        sheet = contact_sheet(camera, sheet_distances(camera), (0, 45))
        _written(args.sheet, lambda: save_figure(sheet, args.sheet))
        print(f"wrote {args.sheet}")


def _print_fit(rows: list[FitRow], measured: Measured, result: Sweep, column: int) -> None:
    print(
        "\nat the measured distances, head-on:\n"
        "distance  error %: measured rendered ok   detection %: measured rendered ok"
    )
    print(
        "(ok: yes when the rendered value is close enough to the measured one: a mean error\n"
        " within a factor 1.5 or 1 point, a detection rate within 15 points; NO when it is\n"
        " not; - where either camera detected too rarely to measure an error)"
    )
    for row in rows:
        error_ok = {None: "-", True: "yes", False: "NO"}[row.error_ok]
        print(
            f"{row.distance_mm:6.0f} mm {row.measured_error_pct:16.2f} "
            f"{row.rendered_error_pct:8.2f} {error_ok:>4}"
            f" {row.measured_detect_pct:22.2f} {row.rendered_detect_pct:8.2f} "
            f"{'yes' if row.detection_ok else 'NO':>3}"
        )
    measured_limit = blind_limit_mm(measured.distances_mm, measured.detect_pct / 100.0)
    rendered_limit = blind_limit_mm(result.distances_mm, result.detection[:, column])
    print(
        f"blind limit: measured {measured_limit:.1f} mm, rendered {rendered_limit:.1f} mm "
        f"({'within' if abs(measured_limit - rendered_limit) <= 5 else 'NOT within'} 5 mm)"
    )


def _patterns(args: argparse.Namespace, camera: Camera, measured: Measured | None) -> int:
    distances = (
        tuple(sorted(set(args.distances)))
        if args.distances
        else pattern_distances(camera, measured)
    )
    ids = range(camera.dictionary_size)
    result = marker_sweep(
        camera, distances, ids, args.frames, args.seed, _progress(args.quiet, "markers")
    )
    print(
        f"camera {camera.name}: {len(ids)} markers of {camera.marker_dictionary} head-on, "
        f"{args.frames} frames at each of {len(distances)} distances"
    )
    print(
        "distance  error %:"
        + (" measured" if measured is not None else "")
        + f"  id {camera.marker_id}    min median    max"
    )
    own = camera.marker_id  # rows are ids 0, 1, ...
    table = {} if measured is None else dict(zip(measured.distances_mm, measured.error_pct))
    for column, distance in enumerate(distances):
        errors = 100.0 * result.reliable_error[:, column]
        known = errors[np.isfinite(errors)]
        spread = (known.min(), np.median(known), known.max()) if known.size else (math.nan,) * 3
        print(
            f"{distance:6.0f} mm"
            + ("" if measured is None else f" {_percent(table.get(distance)):>16}")
            + "".join(f" {_percent(value):>6}" for value in (errors[own], *spread))
        )
    ranked, score = result.least_error()
    print(
        "least error on average: "
        + ", ".join(
            f"id {marker} ({100 * value:.2f} %)" for marker, value in zip(ranked[:10], score)
        )
    )
    if args.plot:
        from ..study.camera import pattern_figure, save_figure

        figure = pattern_figure(result, camera, measured)
        _written(args.plot, lambda: save_figure(figure, args.plot))
        print(f"wrote {args.plot}")
    return 0


def _percent(value: float | None) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.2f}"


def _fit(args: argparse.Namespace, camera: Camera, measured: Measured | None) -> int:
    if measured is None:
        raise SensorError("fit needs --measured CSV")
    grid: dict[str, Sequence[float]] = {
        "residual_blur_px": (0.45, 0.55, 0.65),
        "read_noise": (2.0, 4.0),
        "corner_window_px": (10, 11, 12),
    }
    ranked = fit_degradations(
        camera,
        measured,
        grid,
        frames=args.frames,
        seed=args.seed,
        on_progress=_progress(args.quiet, "fit"),
    )
    for setting, score, rows in ranked[: args.top]:
        passed = sum(bool(r.detection_ok) for r in rows) + sum(bool(r.error_ok) for r in rows)
        print(
            f"score {score:8.2f}  {passed} checks pass  "
            + " ".join(f"{k}={v}" for k, v in setting.items())
        )
    return 0
