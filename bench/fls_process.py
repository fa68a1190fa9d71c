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

from bench.common import REPO, resident_mb


def fls_process_section(args: argparse.Namespace) -> list[str]:
    """One FLS in its own process: resident memory and time from start to discovery-ready."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from swazure_interfaces.srv import ComputePose

    venv = Path(sys.executable).parents[1]
    programs = venv / "lib" / "swazure_ros"
    if not (programs / "fls").exists():
        return ["## One FLS per process", "", "Skipped: `make setup` makes the programs."]
    domain = 151
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    trio = ["-p", f"cloud:={REPO / 'config/track/trio.xyz'}", "-p", "radius:=0.5"]
    camera_sensor = REPO / "config" / "cameras" / "sensor-wide-camera.yaml"

    logs = Path(tempfile.mkdtemp(prefix="swazure-bench-"))
    log_of: dict[int, Path] = {}

    def start(program: str, *extra: str) -> subprocess.Popen[bytes]:
        path = logs / f"{program}-{len(log_of)}.log"
        with path.open("w") as log:
            process = subprocess.Popen(
                [str(programs / program), "--ros-args", *trio, *extra],
                env=env,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        log_of[process.pid] = path
        return process

    def own_ready(pid: int) -> float:
        """Seconds from start to ready, as the program's own log line says."""
        found = re.search(r"ready, ([0-9.]+) s after the start", log_of[pid].read_text())
        return float(found[1]) if found else float("nan")

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    probe = Node("bench_probe", context=context, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)

    def ready(fls_id: int) -> bool:
        # In the graph with its radio, made at its camera's first frame. Not yet listening
        # to the round clock: that waits until every FLS of the trio and the coordinator
        # hear it (fls_program.RadioJoin), and they start one after the other.
        return any(
            info.node_name == f"fls_{fls_id}"
            for info in probe.get_publishers_info_by_topic("/swarm/round_acks")
        )

    processes = [start("world")]
    rows = []
    try:
        time.sleep(3.0)  # the simulator first, as a swarm's launch would have it
        for fls_id, extra in ((0, ()), (1, ()), (2, ())):
            began = time.monotonic()
            process = start("fls", "-p", f"fls_id:={fls_id}", *extra)
            processes.append(process)
            while not ready(fls_id) and time.monotonic() - began < 60:
                executor.spin_once(timeout_sec=0.01)
            rows.append([fls_id, time.monotonic() - began, process.pid])
        time.sleep(2.0)
        at_ready = [resident_mb(pid) for _, _, pid in rows]
        processes.append(start("coordinator"))
        client = probe.create_client(ComputePose, "/swarm/coordinator/compute_pose")
        client.wait_for_service(timeout_sec=60)
        began = time.monotonic()
        future = client.call_async(ComputePose.Request(source_id=0, target_id=2, policy=1))
        while not future.done() and time.monotonic() - began < 120:
            executor.spin_once(timeout_sec=0.05)
        pose_seconds = time.monotonic() - began
        after = [resident_mb(pid) for _, _, pid in rows]
        # A camera-kind FLS: its sensor loads OpenCV.
        began = time.monotonic()
        camera = start("fls", "-p", "fls_id:=1", "-p", f"sensor:={camera_sensor}",
                       "-p", "namespace:=camera_swarm")  # fmt: skip
        processes.append(camera)
        while time.monotonic() - began < 60:
            # No simulator in its namespace gives it a frame: its node in the graph.
            if ("fls_1", "/camera_swarm") in probe.get_node_names_and_namespaces():
                break
            executor.spin_once(timeout_sec=0.01)
        camera_seconds = time.monotonic() - began
        time.sleep(2.0)
        camera_mb = resident_mb(camera.pid)
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.wait(timeout=30)
        executor.shutdown()
        probe.destroy_node()
        context.try_shutdown()
    lines = [
        "## One FLS per process",
        "",
        "`ros2 run swazure_ros fls` on the trio (config/swarms/trio.yaml), the world",
        "program already up. Ready: the process has built its node and radio and spins",
        "(its own log line, interpreter start included); seen: a peer's graph shows its",
        "radio, made at its camera's first frame (DDS discovery added).",
        "Memory: resident, 2 s after ready, then after its first discovery run",
        "(compute_pose 0 -> 2 through the coordinator; the FLS runs its kernels as",
        "Python, core.jit.interpret).",
        "",
        "| FLS | start to ready s (its log) | until a peer sees its radio s "
        "| resident at ready MB | after a discovery run MB |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    for (fls_id, seconds, pid), ready_mb, after_mb in zip(rows, at_ready, after, strict=True):
        lines.append(
            f"| {fls_id} | {own_ready(pid):.2f} | {seconds:.2f} "
            f"| {ready_mb:.0f} | {after_mb:.0f} |"
        )
    lines += [
        "",
        f"The pose query took {pose_seconds:.2f} s. A camera-kind FLS (sensor "
        f"`{camera_sensor.relative_to(REPO)}`, which loads OpenCV): {own_ready(camera.pid):.2f} s "
        f"to ready by its log ({camera_seconds:.2f} s until a peer sees its node), "
        f"{camera_mb:.0f} MB resident. Targets (issue 31): at most 80 MB and "
        "under 1 s for a published-model FLS.",
    ]
    return lines
