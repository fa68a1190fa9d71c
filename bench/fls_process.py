"""One FLS in its own process: resident memory and time from start to discovery-ready.

The `fls_process` section of BENCHMARKS.md (`python -m bench --sections fls_process`).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from bench.common import REPO, resident_mb

CAMERA_SENSOR = REPO / "config" / "cameras" / "sensor-wide-camera.yaml"


class Programs:
    """The swarm's programs of this venv, started on the trio with a log each."""

    def __init__(self, folder: Path, domain: int) -> None:
        self.folder = folder
        self.env = dict(
            os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST"
        )
        self.logs = Path(tempfile.mkdtemp(prefix="swazure-bench-"))
        self.log_of: dict[int, Path] = {}

    def start(self, program: str, *extra: str) -> subprocess.Popen[bytes]:
        """``program`` on the trio with the ROS arguments ``extra``, its output to its log."""
        trio = ["--cloud", str(REPO / "config/track/trio.xyz"), "--radius", "0.5"]
        path = self.logs / f"{program}-{len(self.log_of)}.log"
        with path.open("w") as log:
            process = subprocess.Popen(
                [str(self.folder / program), *trio, *extra],
                env=self.env,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        self.log_of[process.pid] = path
        return process

    def own_ready(self, pid: int) -> float:
        """Seconds from start to ready, as the program's own log line says."""
        found = re.search(r"ready, ([0-9.]+) s after the start", self.log_of[pid].read_text())
        return float(found[1]) if found else float("nan")


def fls_process_section(args: argparse.Namespace, domain: int = 151) -> list[str]:
    """One FLS in its own process: resident memory and time from start to discovery-ready."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node

    folder = Path(sys.executable).parents[1] / "lib" / "swazure_ros"
    if not (folder / "fls").exists():
        return ["## One FLS per process", "", "Skipped: `make setup` makes the programs."]
    programs = Programs(folder, domain)
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    probe = Node("bench_probe", context=context, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    processes = [programs.start("world")]
    try:
        time.sleep(3.0)  # the simulator first, as a swarm's launch would have it
        rows = started_trio(programs, processes, probe, executor)
        time.sleep(2.0)
        at_ready = [resident_mb(pid) for _, _, pid in rows]
        processes.append(programs.start("coordinator"))
        pose_seconds = pose_query_seconds(probe, executor)
        after = [resident_mb(pid) for _, _, pid in rows]
        camera = camera_fls(programs, processes, probe, executor)
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait(timeout=30)
        executor.shutdown()
        probe.destroy_node()
        context.try_shutdown()
    measured = [
        (fls_id, programs.own_ready(pid), seconds, ready_mb, after_mb)
        for (fls_id, seconds, pid), ready_mb, after_mb in zip(rows, at_ready, after, strict=True)
    ]
    return fls_process_lines(measured, pose_seconds, camera)


def started_trio(
    programs: Programs, processes: list[Any], probe: Any, executor: Any
) -> list[tuple[int, float, int]]:
    """The trio's FLSs started one after the other: id, seconds until seen, process id."""

    def ready(fls_id: int) -> bool:
        # In the graph with its radio, made at its camera's first frame. Not yet listening
        # to the round clock: that waits until every FLS of the trio and the coordinator
        # hear it (fls_program.RadioJoin), and they start one after the other.
        return any(
            info.node_name == f"fls_{fls_id}"
            for info in probe.get_publishers_info_by_topic("/swarm/round_acks")
        )

    rows = []
    for fls_id in (0, 1, 2):
        began = time.monotonic()
        process = programs.start("fls", "--fls-id", str(fls_id))
        processes.append(process)
        while not ready(fls_id) and time.monotonic() - began < 60:
            executor.spin_once(timeout_sec=0.01)
        rows.append((fls_id, time.monotonic() - began, process.pid))
    return rows


def pose_query_seconds(probe: Any, executor: Any) -> float:
    """How long the coordinator takes to answer compute_pose 0 -> 2, s."""
    from swazure_interfaces.srv import ComputePose

    client = probe.create_client(ComputePose, "/swarm/coordinator/compute_pose")
    client.wait_for_service(timeout_sec=60)
    began = time.monotonic()
    future = client.call_async(ComputePose.Request(source_id=0, target_id=2, policy=1))
    while not future.done() and time.monotonic() - began < 120:
        executor.spin_once(timeout_sec=0.05)
    return time.monotonic() - began


def camera_fls(
    programs: Programs, processes: list[Any], probe: Any, executor: Any
) -> tuple[float, float, float]:
    """A camera-kind FLS (its sensor loads OpenCV): s to ready by its log, until seen, MB."""
    began = time.monotonic()
    camera = programs.start("fls", "--fls-id", "1", "--sensor", str(CAMERA_SENSOR),
                            "--namespace", "camera_swarm")  # fmt: skip
    processes.append(camera)
    while time.monotonic() - began < 60:
        # No simulator in its namespace gives it a frame: its node in the graph.
        if ("fls_1", "/camera_swarm") in probe.get_node_names_and_namespaces():
            break
        executor.spin_once(timeout_sec=0.01)
    camera_seconds = time.monotonic() - began
    time.sleep(2.0)
    return programs.own_ready(camera.pid), camera_seconds, resident_mb(camera.pid)


def fls_process_lines(
    rows: list[tuple[int, float, float, float, float]],
    pose_seconds: float,
    camera: tuple[float, float, float],
) -> list[str]:
    """The section from each FLS's id, s to ready (log), s until seen, MB at ready and after."""
    camera_ready, camera_seconds, camera_mb = camera
    lines = [
        "## One FLS per process",
        "",
        "`ros2 run swazure_ros fls` on the trio (config/swarms/trio.yaml), the world",
        "program already up. Ready: the process has built its node and radio and spins",
        "(its own log line, interpreter start included); seen: a peer's graph shows its",
        "radio, made at its camera's first frame (DDS discovery added).",
        "Memory: resident, 2 s after ready, then after its first discovery run",
        "(compute_pose 0 -> 2 through the coordinator; the FLS runs its kernels as",
        "Python, NUMBA_DISABLE_JIT=1: core.jit).",
        "",
        "| FLS | start to ready s (its log) | until a peer sees its radio s "
        "| resident at ready MB | after a discovery run MB |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for fls_id, own_ready, seconds, ready_mb, after_mb in rows:
        lines.append(
            f"| {fls_id} | {own_ready:.2f} | {seconds:.2f} | {ready_mb:.0f} | {after_mb:.0f} |"
        )
    lines += [
        "",
        f"The pose query took {pose_seconds:.2f} s. A camera-kind FLS (sensor "
        f"`{CAMERA_SENSOR.relative_to(REPO)}`, which loads OpenCV): {camera_ready:.2f} s "
        f"to ready by its log ({camera_seconds:.2f} s until a peer sees its node), "
        f"{camera_mb:.0f} MB resident. Targets (issue 31): at most 80 MB and "
        "under 1 s for a published-model FLS.",
    ]
    return lines
