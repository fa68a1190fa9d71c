"""Estimation errors of a tracked target, with and without delay compensation.

The `tracking` section of BENCHMARKS.md (`python -m bench --sections tracking`).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from bench.common import DATASETS, REPO, SWAZURE, run_output

TRACK_DIR = REPO / "config" / "track"


TRACK_CLOUD = ["--cloud", str(TRACK_DIR / "trio.xyz"), "--scale", "1", "--radius", "0.5"]


TRACK_SCENARIOS = [
    ("constant velocity", "linear:0,0,0.2"),
    ("circle", "circle:0.5,4,-1,1,0"),
    ("waypoints", str(TRACK_DIR / "zigzag.csv")),
]


#: The `swazure track` runs over ROS 2: (cloud options, source and target, trajectory, label).
TRACK_RUNS = (
    (TRACK_CLOUD, ["--source", "0", "--target", "2"], "circle:0.5,4,-1,1,0", "trio"),
    (
        ["--cloud", str(DATASETS / "chess_408.xyz"), "--beta", "0.3"],
        ["--source", "0", "--target", "1"],
        "linear:0,0,0.02",
        "chess_408, beta 0.3",
    ),
    (
        ["--cloud", "torus", "--beta", "0.5"],
        ["--source", "0", "--target", "1"],
        "circle:0.3,4",
        "torus, beta 0.5",
    ),
)


def track_errors_row(trajectory: str, accurate: bool, delay: float, model: str) -> list[str]:
    """One core track of the trio swarm (10 s); its errors as table cells, mean (max)."""
    from swazure_ros.core.motion import Motion
    from swazure_ros.core.tracking import TrackConfig, track_errors, track_series
    from swazure_ros.files.cloud_files import load_cloud
    from swazure_ros.files.sensors import load_sensor
    from swazure_ros.files.trajectories import parse_trajectory
    from swazure_ros.protocol.loops import simulate_track
    from swazure_ros.sim.world import make_world

    sensor = load_sensor()
    world = make_world(
        load_cloud(str(TRACK_DIR / "trio.xyz"), 1.0),
        sensor.error_free() if accurate else sensor,
        radius=0.5,
    )
    motion = Motion({2: parse_trajectory(trajectory)})
    config = TrackConfig(communication_delay=delay, model=model)
    points, ids, radius = world.swarm.points, world.ids, world.swarm.radius
    run_ = simulate_track(world.sensor, points, ids, radius, motion, 0, 2, config, 10.0)
    errors = track_errors(track_series(run_, motion, points[0], points[2]), settle=1.0)
    cells = []
    for quantity in ("position", "velocity", "acceleration"):
        for estimator in ("raw", "predicted"):
            mean, peak = errors[quantity][estimator]
            cells.append(f"{mean:.4f} ({peak:.3f})")
    return cells


def tracking_section(
    args: argparse.Namespace,
    scenarios: Sequence[tuple[str, str]] = TRACK_SCENARIOS,
    runs: Sequence[tuple[list[str], list[str], str, str]] = TRACK_RUNS,
    domain: int = 93,
) -> list[str]:
    """Estimation errors of a tracked target, with and without delay compensation."""
    lines = [
        "## Tracking a moving FLS out of sight (`swazure track`), errors per scenario",
        "",
        "The swarm of config/track/trio.xyz (r = 0.5 cm): source 0, relay 1 in its sweet range,",
        "target 2 blind to the source and seen by the relay. The target flies 10 s of simulated",
        "time; the relay samples every 0.1 s. Error norms against the true relative motion at",
        "the present (the moment each sample arrives), after the first second, mean (max).",
        "Received: the last sample (position) and central differences (velocity one, acceleration",
        "two sample intervals older): no compensation. Predicted: the Kalman filter predicted",
        "to the present, delay compensated. Filter: filterpy KalmanFilter, process noise 10,",
        "measurement noise 0.05 cm (the defaults).",
        "",
        "| trajectory | error model | delay s | model | position received cm | position predicted "
        "| velocity received cm/s | velocity predicted | accel. received cm/s² "
        "| accel. predicted |",
        "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for label, trajectory in scenarios:
        for accurate in (True, False):
            for delay in (0.0, 0.3):
                for model in ("constant-velocity", "constant-acceleration"):
                    cells = track_errors_row(trajectory, accurate, delay, model)
                    lines.append(
                        f"| {label} | {'off' if accurate else 'on'} | {delay:g} | {model} | "
                        + " | ".join(cells)
                        + " |"
                    )
    lines += [
        "",
        "Over ROS 2 (`swazure track`, the nodes on a simulated /clock, one process), wall time",
        "of the whole command, delay 0.3 s, 10 s simulated:",
        "",
        "| swarm | trajectory | nodes | handovers | wall s | peak MB | identical to the core |",
        "| --- | --- | ---: | ---: | ---: | ---: | --- |",
    ]
    for cloud, options, trajectory, label in runs:
        lines.append(track_run_row(cloud, options, trajectory, label, domain))
    lines += [
        "",
        "On the published shapes neighbours are a few millimetres apart: a moving target soon",
        "has another FLS in its relay's line of sight, and the source hands the stream over to",
        "another relay that sees it (docs/tracking.md).",
    ]
    return [*lines, ""]


def track_run_row(
    cloud: list[str], options: list[str], trajectory: str, label: str, domain: int = 93
) -> str:
    """One `swazure track` over ROS 2 (delay 0.3 s): its handovers, wall, peak and identity."""
    wall, peak, code, output = run_output(
        [*SWAZURE, "track", *cloud, *options, "--trajectory", trajectory,
         "--communication-delay", "0.3", "--domain-id", str(domain)]
    )  # fmt: skip
    identical = "yes" if "identical to the core's loop: yes" in output else f"no (exit {code})"
    nodes = "3" if label == "trio" else "source, target, sweet neighbours"
    handovers = output.count("handed over from relay")
    return (
        f"| {label} | {trajectory} | {nodes} | {handovers} | {wall:.1f} | {peak:.0f} "
        f"| {identical} |"
    )
