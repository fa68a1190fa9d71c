"""Least-error against the paper's two policies: errors and engine time (issue 19).

The `policies` section of BENCHMARKS.md (`python -m bench --sections policies`).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from pathlib import Path

from bench.common import REPO, SHAPES, SWAZURE, run, swarm_cloud
from swazure_ros.core.summary import Summary
from swazure_ros.files.results import SUMMARY_FILE
from swazure_ros.files.runs import read_summary

POLICY_SENSORS = {
    "published": REPO / "config" / "sensor.yaml",
    "wide, calibrated (stochastic)": REPO / "config" / "cameras" / "sensor-wide-calibrated.yaml",
}


POLICY_BETAS = (0.3, 0.4, 0.5)


def evaluated(out: Path, shape: str, beta: float, sensor: Path, *options: str) -> Summary:
    """summary.json of `swazure evaluate` of a published shape into ``out``; exits on failure."""
    code = run(
        [*SWAZURE, "evaluate", "--cloud", swarm_cloud(shape), "--beta", str(beta),
         "--sensor", str(sensor), "--quiet", "--out", str(out), *options]
    )[2]  # fmt: skip
    if code != 0:
        raise SystemExit(f"bench: evaluate {shape} {beta} {' '.join(options)} failed ({code})")
    return read_summary(out / SUMMARY_FILE)


def policies_section(
    args: argparse.Namespace,
    shapes: Sequence[str] = SHAPES,
    betas: Sequence[float] = POLICY_BETAS,
    sensors: dict[str, Path] = POLICY_SENSORS,
) -> list[str]:
    """Least-error against the paper's two policies: errors and engine time (issue 19)."""
    lines = [
        "## Path policies: Least-Error against the paper's two, plain Swazure",
        "",
        "`swazure evaluate --policy P --sensor S` per shape, beta and sensor; engine seconds",
        "are the evaluation's own (summary.json `seconds`, neighbourhood included), distance",
        "error and alpha are means over the pairs with a path. Least-Error minimises the summed",
        'expected hop error (docs/core.md, "Least-error paths").',
        "",
        "| shape | β | sensor | distance error % FH / SL / LE | α° SL / LE | LE < SL | "
        "engine s SL / LE | LE / SL time |",
        "| --- | ---: | --- | --- | --- | :---: | --- | ---: |",
    ]
    with tempfile.TemporaryDirectory() as scratch:
        for shape in shapes:
            for beta in betas:
                for sensor_name, sensor in sensors.items():
                    found: dict[str, Summary] = {}
                    for policy in ("fewest-hops", "shortest-length", "least-error"):
                        out = Path(scratch) / f"{shape}-{beta}-{policy}-{len(found)}"
                        found[policy] = evaluated(out, shape, beta, sensor, "--policy", policy)
                    row = policies_row(shape, beta, sensor_name, found)
                    print(row, flush=True)
                    lines.append(row)
    return lines


def policies_row(shape: str, beta: float, sensor_name: str, found: dict[str, Summary]) -> str:
    """One row: the three policies' errors and engine times from their summary.json."""
    error = {p: one.pairs.distance_error_pct.mean or 0.0 for p, one in found.items()}
    alpha = {p: one.pairs.alpha_deg.mean or 0.0 for p, one in found.items()}
    seconds = {p: one.seconds or 0.0 for p, one in found.items()}
    sl, le = "shortest-length", "least-error"
    return (
        f"| {shape} | {beta:g} | {sensor_name} | "
        f"{error['fewest-hops']:.3f} / {error[sl]:.3f} / {error[le]:.3f} | "
        f"{alpha[sl]:.3f} / {alpha[le]:.3f} | "
        f"{'yes' if error[le] < error[sl] else '**no**'} | "
        f"{seconds[sl]:.2f} / {seconds[le]:.2f} | "
        f"{seconds[le] / seconds[sl]:.2f} |"
    )
