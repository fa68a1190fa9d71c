"""Discovery beside busy loops: slow is not dead, and FLS processes that come back.

The `under_load` section of BENCHMARKS.md (`python -m bench --sections under_load`):
the race car packed (`swazure spawn --compute-all`) and grid25 in 25 FLS processes,
quiet and beside busy loops (`python -c 'while True: pass'`, started and killed
here); then grid25's FLS 12 stopped past its lease, and killed and started again,
beside the same loops (docs/protocol.md, "Slow is not dead", "Coming back").
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from bench.common import REPO, RUN_LIMIT, compute_all, swarm_cloud, table_cell
from bench.faults import same

POLICY = "shortest-length"
#: Busy loops beside the swarm, one more than each core can take at once (2 cores).
BUSY_LOOPS = 4
GRID = REPO / "config" / "swarms" / "grid25.xyz"
#: Fast DDS's 5 s lease (announced every 1 s), for every participant of a swarm.
SHORT_LEASE = REPO / "config" / "fastdds.xml"
#: How each come-back case stops its FLS: (label, lease profile or None, seconds stopped).
STOPS = (
    ("stopped 12 s past a 5 s lease", SHORT_LEASE, 12.0),
    ("stopped 30 s past the default 20 s lease", None, 30.0),
)


@contextlib.contextmanager
def busy_loops(count: int) -> Iterator[None]:
    """``count`` processes that keep a core busy each, for the block's time."""
    loops = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(count)]
    try:
        yield
    finally:
        for loop in loops:
            loop.kill()
            loop.wait()


def under_load_section(
    args: argparse.Namespace,
    packed: str = "racecar_3720",
    grid: Path = GRID,
    runs: int = 5,
    fls: int = 12,
    stops: tuple[tuple[str, Path | None, float], ...] = STOPS,
    loops: int = BUSY_LOOPS,
    domain: int = 96,
) -> list[str]:
    """Discovery beside busy loops: slow is not dead, and FLS processes that come back."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    lines = [
        "## Under load",
        "",
        "### Slow is not dead: discovery beside busy loops",
        "",
        f"Beside {loops} busy loops (`python -c 'while True: pass'`, at the launcher's",
        "priority; the FLS processes run at nice 10) and whatever else the machine ran;",
        f"load is the 1-minute load average at the run's end. {packed} packed in two processes",
        "(`swazure spawn --compute-all`, every blind pair against the engine);",
        f"{grid.stem} with one process per FLS (`RunningSwarm`), once quiet and brought up",
        f"{runs} times beside the loops. Default parameters (`round_timeout` 10 s).",
        "Processes: in all, the launcher's included; peak MB: their peaks summed;",
        "restarts: phases begun again.",
        "",
        "| swarm | processes | busy loops | load | bring-up s | discovery s | rounds "
        "| restarts | departed | identical | peak MB |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |",
    ]
    for busy in (0, loops):
        with busy_loops(busy):
            lines.append(packed_row(args, packed, busy, domain))
    for run in range(1 + runs):
        busy = loops if run else 0
        with busy_loops(busy):
            lines.append(grid_row(grid, busy, domain))
    lines += [
        "",
        "### Coming back: an FLS process stopped past its lease, or killed and started again",
        "",
        f"{grid.stem} in FLS processes beside {loops} busy loops; FLS {fls}, on many paths.",
        "Stopped: `kill -STOP` until the coordinator's graph shows it gone (its lease ran",
        "out) and for the time given, then `kill -CONT`. Killed: SIGKILL,",
        "one run without it, then its process started again with its id",
        "(`FlsProcesses.restart`). Back: from `kill -CONT` or the start until a run has no FLS",
        "departed; runs: those runs. Every participant of a swarm has the same lease.",
        "",
        "| case | gone after s | back after s | runs | departed at the end | identical |",
        "| --- | ---: | ---: | ---: | --- | --- |",
    ]
    with busy_loops(loops):
        for label, lease, seconds in stops:
            lines.append(come_back_row(grid, fls, label, lease, seconds, domain))
        lines.append(come_back_row(grid, fls, "killed, started again", None, 0.0, domain))
    return [*lines, ""]


def packed_row(args: argparse.Namespace, shape: str, loops: int, domain: int) -> str:
    """``shape`` packed in two processes, ``swazure spawn --compute-all``: its table row."""
    # Busy loops take the cores' time: the run's own limit grows with them (the race car
    # beside 4 of them was still going at the quiet limit, 12 min).
    limit = RUN_LIMIT["plain"] * (1 + loops)
    with tempfile.TemporaryDirectory() as out:
        found = compute_all(swarm_cloud(shape), "plain", domain, Path(out), 2, limit)
    load = os.getloadavg()[0]
    if "failed" in found:
        return f"| {shape} | 2 | {loops} | {load:.1f} | {found['failed']} |  |  |  |  |  |  |"
    return (
        f"| {shape} | 2 | {loops} | {load:.1f} | {table_cell(found, 'bring_up', '.1f')} "
        f"| {table_cell(found, 'discovery', '.1f')} | {found['rounds']} | {found['restarts']} "
        f"| {found['departed']} | {found['identical']} | {found['peak']} |"
    )


def grid_swarm(grid: Path, domain: int, logs: str) -> Any:
    """A RunningSwarm of ``grid`` (cm, FLS radius 0.5 cm), one process per FLS."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    spec = WorldSpec(cloud=str(grid), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=logs, discovery_timeout=600, domain_id=domain)
    return RunningSwarm.start(config)


def grid_row(grid: Path, loops: int, domain: int) -> str:
    """One bring-up of ``grid`` in FLS processes and one discovery: its table row."""
    from swazure_ros.core.evaluate import evaluate_pairs

    with tempfile.TemporaryDirectory() as logs, grid_swarm(grid, domain, logs) as swarm:
        up = swarm.bring_up
        result = swarm.discover(POLICY, timeout=1800)
        load = os.getloadavg()[0]
        run = result.outcome
        identical = same(swarm.world, result, evaluate_pairs(swarm.world.hood, POLICY))
        peak = sum(up.peak_rss_mb)
    return (
        f"| {grid.stem} | {up.processes} | {loops} | {load:.1f} | {up.seconds:.1f} "
        f"| {result.seconds:.1f} | {run.rounds} | {run.restarts} | {len(run.departed)} "
        f"| {identical} | {peak:.0f} |"
    )


def come_back_row(
    grid: Path, fls: int, label: str, lease: Path | None, stopped: float, domain: int
) -> str:
    """FLS ``fls`` stopped for ``stopped`` s under ``lease`` (0: killed, started again)."""
    from swazure_ros.core.evaluate import evaluate_pairs

    saved = os.environ.pop("FASTRTPS_DEFAULT_PROFILES_FILE", None)
    if lease is not None:
        os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(lease)
    try:
        with tempfile.TemporaryDirectory() as logs, grid_swarm(grid, domain, logs) as swarm:
            gone_after, began = stop_or_kill(swarm, fls, stopped)
            runs: list[Any] = []
            while not runs or (runs[-1].outcome.departed and time.monotonic() < began + 300):
                swarm.spin(1.0)
                runs.append(swarm.discover(POLICY, timeout=600))
            back = time.monotonic() - began
            last = runs[-1]
            identical = same(swarm.world, last, evaluate_pairs(swarm.world.hood, POLICY))
    finally:
        os.environ.pop("FASTRTPS_DEFAULT_PROFILES_FILE", None)
        if saved is not None:
            os.environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = saved
    departed = sorted(last.outcome.departed)
    return (
        f"| {label} | {gone_after:.1f} | {back:.1f} | {len(runs)} "
        f"| {departed or 'none'} | {identical} |"
    )


def stop_or_kill(swarm: Any, fls: int, stopped: float) -> tuple[float, float]:
    """Stop FLS ``fls``'s process for ``stopped`` s and more until gone (0: kill it, one run
    without it, start it again); seconds until the graph showed it gone, and when it went on."""
    coordinator = swarm.coordinator
    process = swarm.processes.fls.processes[fls]
    began = time.monotonic()

    def wait_gone() -> float:
        while fls not in coordinator.membership.gone and time.monotonic() < began + 300:
            swarm.spin(0.2)
        return time.monotonic() - began

    if stopped <= 0.0:
        process.kill()
        gone_after = wait_gone()
        swarm.discover(POLICY, timeout=600)
        swarm.processes.restart(fls)
        return gone_after, time.monotonic()
    os.kill(process.pid, signal.SIGSTOP)
    try:
        gone_after = wait_gone()
        while time.monotonic() < began + stopped:
            swarm.spin(0.2)
    finally:
        os.kill(process.pid, signal.SIGCONT)
    return gone_after, time.monotonic()
