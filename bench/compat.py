"""The heuristics as the text describes them beside the published code, every shape.

The `compat` section of BENCHMARKS.md (`python -m bench --sections compat`).
"""

from __future__ import annotations

import argparse
import shutil
from collections.abc import Sequence
from pathlib import Path

from bench.common import REPO, SECTIONS_DIR, SWAZURE, run_output


def compat_section(
    args: argparse.Namespace,
    betas: Sequence[str] = ("0.3", "0.4", "0.5"),
    options: Sequence[str] = (),
    records_dir: Path = SECTIONS_DIR,
) -> list[str]:
    """The heuristics as the text describes them beside the published code, every shape.

    ``options`` narrow the study (a smoke test's: its clouds and heuristics).
    """
    import csv

    out = records_dir / "compat-study"
    if out.exists():
        shutil.rmtree(out)
    command = [*SWAZURE, "study", "--betas", *betas, "--policies",
               "shortest-length", "--compat", "published", "--out", str(out),
               "--quiet", *options]  # fmt: skip
    seconds, memory, code, _ = run_output(command)
    lines = [
        "## The published code beside the text: `swazure study --compat published`",
        "",
        f"`{' '.join(['swazure', *command[len(SWAZURE) :]]).replace(str(REPO) + '/', '')}`: "
        f"{seconds:.0f} s, "
        f"peak {memory:.0f} MB. Per shape, beta and heuristic (policy shortest-length): the",
        "text's number / the published code's. The published code's are what the paper's",
        "Tables 2 and 3 report; the one cell the paper's text quotes, Move Obstructing on the",
        "chess piece at beta 0.5, is 21.43 % no path there and here. Table 3's metric is the",
        "distance moved per resolved pair (for Move Source the published code reports the",
        "distance flown, averaged over the pairs tried).",
        "",
    ]
    if code != 0:
        return [*lines, f"The study failed (exit {code}).", ""]
    with (out / "tables" / "compat_text_vs_published.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    lines += [
        "| shape | β | heuristic | no path % | decaying % | resolved | moved per resolved "
        "pair, cm | flown per tried pair, cm |",
        "| --- | ---: | --- | --- | --- | --- | --- | --- |",
    ]

    def cell(row: dict[str, str], key: str, digits: int) -> str:
        values = [row[f"{key}_{mode}"] for mode in ("text", "published")]
        return " / ".join("-" if not v else f"{float(v):,.{digits}f}" for v in values)

    for row in rows:
        lines.append(
            f"| {row['shape']} | {row['beta']} | {row['technique']} "
            f"| {cell(row, 'no_path_pct', 2)} | {cell(row, 'decaying_pct', 2)} "
            f"| {cell(row, 'resolved', 0)} | {cell(row, 'per_pair_mean_cm', 3)} "
            f"| {cell(row, 'flown_mean_cm', 2)} |"
        )
    return [*lines, ""]
