"""Benchmarks of the core engine and the swarm; writes BENCHMARKS.md (run by `make bench`).

Each run is a separate `swazure evaluate` process, timed from outside (wall
time, process start included) with its peak resident memory from wait4.
Needs the published point clouds in ../shared/datasets/swazure-paper/.
"""

from __future__ import annotations

import argparse
import datetime
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from bench.camera import camera_section
from bench.cells import cells_section
from bench.common import (
    DATASETS,
    REPO,
    SECTIONS_DIR,
    compute_all,
    held_domains,
    machine,
    measured_commit,
    merged,
    stamped,
)
from bench.compat import compat_section
from bench.discovery import discovery_section
from bench.display import display_section
from bench.display_memory import display_memory_section
from bench.engine import engine_section
from bench.exits import exits_section
from bench.faults import faults_section
from bench.fls_process import fls_process_section
from bench.fusion import fusion_section
from bench.hostile import hostile_section
from bench.hosts import hosts_section
from bench.labels import labels_section
from bench.least_squares import least_squares_section
from bench.policies import policies_section
from bench.replay import replay_section
from bench.scale import scale_section
from bench.soak import soak_section
from bench.speed import speed_section
from bench.study import study_section
from bench.swarm import swarm_section
from bench.swarm_fit import swarm_fit_section
from bench.swarm_solve import swarm_solve_section
from bench.tags import tags_section
from bench.test_suite import test_suite_section
from bench.tracking import tracking_section
from bench.under_load import under_load_section

SECTIONS: dict[str, Callable[..., list[str]]] = {
    "engine": engine_section,
    "speed": speed_section,
    "test_suite": test_suite_section,
    "policies": policies_section,
    "fusion": fusion_section,
    "study": study_section,
    "compat": compat_section,
    "swarm": swarm_section,
    "discovery": discovery_section,
    "tracking": tracking_section,
    "camera": camera_section,
    "soak": soak_section,
    "faults": faults_section,
    "hostile": hostile_section,
    "replay": replay_section,
    "fls_process": fls_process_section,
    "hosts": hosts_section,
    "least_squares": least_squares_section,
    "swarm_fit": swarm_fit_section,
    "swarm_solve": swarm_solve_section,
    "cells": cells_section,
    "labels": labels_section,
    "tags": tags_section,
    "scale": scale_section,
    "display": display_section,
    "display_memory": display_memory_section,
    "exits": exits_section,
    "under_load": under_load_section,
}


def main() -> int:
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    parser.add_argument("--beta", type=float, default=0.5)
    parser.add_argument("--output", type=Path, default=REPO / "BENCHMARKS.md")
    parser.add_argument(
        "--sections",
        nargs="+",
        choices=list(SECTIONS),
        default=list(SECTIONS),
        help="run these sections; the others keep their last results (build/bench/)",
    )
    parser.add_argument(
        "--display-sizes",
        nargs="+",
        type=int,
        metavar="FLSS",
        help="the display section's sizes (default: every size, which takes hours)",
    )
    args = parser.parse_args()
    if not DATASETS.is_dir():
        print(
            f"bench: {DATASETS} is absent; the benchmarks need the published clouds",
            file=sys.stderr,
        )
        return 2
    # The sections' swarms run on fixed domain ids within the tests' range: held, so that
    # a `make test` beside the bench never meets them.
    with held_domains():
        return measure(args)


def measure(args: argparse.Namespace) -> int:
    """Run ``args.sections`` and merge them into ``args.output``."""
    # Warm numba's compilation cache so that no run pays for compiling: the engine's
    # kernels, the heuristics' and the swarm's (make setup compiled them; a swarm's
    # processes run them once more here, in case).
    from swazure_ros.app.warm import warm_kernels

    warm_kernels()
    for technique in ("plain", "move-obstructing", "move-source"):
        with tempfile.TemporaryDirectory() as out:
            compute_all("torus:120", technique, 91, Path(out), 1, 600, "--scale", "1.6")
    SECTIONS_DIR.mkdir(parents=True, exist_ok=True)
    commit = measured_commit()
    for name in args.sections:
        print(f"bench: section {name}", flush=True)
        started = time.perf_counter()
        body = SECTIONS[name](args)
        minutes = (time.perf_counter() - started) / 60
        print(f"bench: section {name} took {minutes:.1f} min", flush=True)
        # The stamp of each section: when, where, on what code and for how long, so that
        # sections run at different times can be told apart (a whole run takes hours).
        stamp = (
            f"Measured {datetime.date.today().isoformat()} on {machine()}; "
            f"commit {commit}; the section took {minutes:.0f} min."
        )
        (SECTIONS_DIR / f"{name}.md").write_text("\n".join([stamp, "", *body]))
    fresh = []
    for name in SECTIONS:
        section = SECTIONS_DIR / f"{name}.md"
        if section.exists():
            text = section.read_text().split("\n")
            fresh.append(stamped(text[2:], text[0]))
    existing = args.output.read_text() if args.output.exists() else ""
    args.output.write_text(merged(existing, fresh))
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
