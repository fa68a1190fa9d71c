"""Multi-path fusion and predicted errors per shape, sensor and policy (issue 19).

The `fusion` section of BENCHMARKS.md (`python -m bench --sections fusion`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path

from bench.common import SHAPES
from bench.policies import POLICY_SENSORS, evaluated
from swazure_ros.core.summary import Summary

# A search per pair and path, or per group of a source's pairs (core.avoiding): the
# kangaroo's K = 3 took about 4 minutes, the larger shapes far longer (the race car's 270 s
# on 2026-12-07); the dragon, skateboard and race car are left to a longer run.
FUSION_SHAPES = SHAPES[:3]


def fusion_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = FUSION_SHAPES,
    sensors: dict[str, Path] = POLICY_SENSORS,
    policies: Sequence[str] = ("shortest-length", "least-error"),
    fused: Sequence[int] = (1, 2, 3),
) -> list[str]:
    """Multi-path fusion and predicted errors per shape, sensor and policy (issue 19)."""
    lines = [
        "## Multi-path fusion: `swazure evaluate --fuse K`, beta 0.5",
        "",
        "Sweet pairs with two or more node-disjoint sweet paths: mean distance error of the",
        'policy\'s path alone and fused from up to K paths; "within": % of all pairs with a',
        "path whose vector error is within the predicted error (K = 1: one path). Fusion s is",
        "the time of the disjoint searches and the fusion beside the engine's own. The three",
        "larger shapes are left out: their disjoint searches take too long for a bench.",
        "",
        "| shape | sensor | policy | K | pairs fused | error % one path -> fused | cut % | "
        "within % | engine s | fusion s |",
        "| --- | --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: |",
    ]
    with tempfile.TemporaryDirectory() as scratch:
        for shape in shapes:
            for sensor_name, sensor in sensors.items():
                for policy in policies:
                    for paths in fused:
                        out = Path(scratch) / f"{shape}-{len(lines)}"
                        summary = evaluated(
                            out, shape, args.beta, sensor, "--policy", policy, "--fuse", str(paths)
                        )
                        row = fusion_row(shape, sensor_name, policy, paths, summary)
                        print(row, flush=True)
                        lines.append(row)
    return lines


def fusion_row(shape: str, sensor_name: str, policy: str, paths: int, summary: Summary) -> str:
    """One row: the fusion of up to ``paths`` paths from its summary.json."""
    within = summary.pairs.within_predicted_pct
    fusion = summary.fusion
    if fusion is None:
        cells = ["-", "-", "-"]
        seconds = "-"
    else:
        one = fusion.distance_error_pct_one_path.mean or 0.0
        fused = fusion.distance_error_pct_fused.mean or 0.0
        cut = 100 * (1 - fused / one) if one else float("nan")
        cells = [f"{fusion.pairs_fused:,}", f"{one:.3f} -> {fused:.3f}", f"{cut:.1f}"]
        seconds = f"{fusion.seconds:.1f}"
    return (
        f"| {shape} | {sensor_name} | {policy} | {paths} | "
        f"{' | '.join(cells)} | {within:.1f} | {summary.seconds or 0.0:.2f} | "
        f"{seconds} |"
    )
