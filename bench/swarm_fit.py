"""Each source's own least-squares fit made by the swarm, beside a plain run.

The `swarm_fit` section of BENCHMARKS.md (`python -m bench --sections swarm_fit`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from bench.common import REPO, RUN_LIMIT, compute_all, swarm_cloud

#: The shapes whose swarm fits in the bench: one process makes every source's fit in
#: turn, where each FLS would make its own (kangaroo 200 s, skateboard 170 s and the
#: race car 45 min of fits alone; BENCHMARKS.md, "Least-squares localization", times one).
FIT_SHAPES = ("chess_408", "palm_725", "dragon_1147")


def swarm_fit_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = FIT_SHAPES,
    estimators: Sequence[str] = ("path", "local-least-squares"),
    domain: int = 93,
) -> list[str]:
    """Each source's own least-squares fit made by the swarm, beside a plain run."""
    sensor = str(REPO / "config" / "cameras" / "sensor-wide-calibrated.yaml")
    lines = [
        "## The swarm's own fits: `spawn --compute-all --estimator local-least-squares`",
        "",
        "One process holds every FLS node (config/swarm.yaml), wide-lens calibrated",
        "stochastic sensor, beta 0.5, Shortest-Length. Each source fits what its radio hears",
        '(docs/protocol.md, "A fitting run"); the engine makes the same windows\' fits',
        "(`evaluate --estimator local-least-squares`). Discovery s is the whole run: the",
        "search and every source's fit, one after the other in this one process. Identical:",
        "every estimate to 1e-9 cm and every covariance to 1e-9 of its largest entry.",
        "",
        "| shape | estimator | discovery s | rounds | messages | MB | engine s | identical "
        "| peak MB |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- | ---: |",
    ]
    for name in shapes:
        for estimator in estimators:
            with tempfile.TemporaryDirectory() as out:
                row = compute_all(
                    swarm_cloud(name), "plain", domain, Path(out), 1, RUN_LIMIT["plain"],
                    "--sensor", sensor, "--estimator", estimator,
                )  # fmt: skip
            print(f"compute-all {name} {estimator}: {row}", flush=True)
            lines.append(swarm_fit_row(name, estimator, row))
    lines += [
        "",
        "Target (issue 33): the swarm's estimates equal the engine's to 1e-9.",
        "",
    ]
    return lines


def swarm_fit_row(name: str, estimator: str, row: dict[str, Any]) -> str:
    """One --compute-all run's row: its time, traffic and identity, or why it failed."""
    if "failed" in row:
        return f"| {name} | {estimator} | {row['failed']} |" + " |" * 6
    return (
        f"| {name} | {estimator} | {row['discovery']:.1f} | {row['rounds']} "
        f"| {row['messages']:,} | {row['bytes'] / 1e6:,.0f} | {row['engine']:.1f} "
        f"| {row['identical']} | {row['peak']} |"
    )
