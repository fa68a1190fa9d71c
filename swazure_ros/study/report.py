"""The study's text outputs: ``tables.md``, one CSV per table, and the one-page ``report.md``."""

from __future__ import annotations

import datetime
import importlib.metadata
import os
import platform
import sys
from pathlib import Path

from ..core.heuristics.compat import PUBLISHED, Compat
from ..files.atomic import atomic_write
from .plan import StudyPlan
from .sweep import SweepResult
from .tables import Table

TABLES_FILE = "tables.md"
REPORT_FILE = "report.md"
PACKAGES = ("swazure_ros", "numpy", "scipy", "numba", "pyarrow", "matplotlib")


def write_text(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically; return the path."""
    atomic_write(path, lambda tmp: tmp.write_text(text))
    return path


def write_tables(out: Path, tables: list[Table]) -> Path:
    """Write ``tables.md`` and ``tables/<name>.csv`` for each table; return tables.md."""
    for table in tables:
        write_text(out / "tables" / f"{table.name}.csv", table.to_csv())
    return write_text(out / TABLES_FILE, tables_markdown(tables))


def tables_markdown(tables: list[Table]) -> str:
    """Every table in Markdown, one after the other."""
    return "\n".join(table.to_markdown() for table in tables)


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def software_versions() -> dict[str, str]:
    """Versions of Python and the packages behind the numbers."""
    versions = {"python": platform.python_version()}
    for package in PACKAGES:
        try:
            versions[package] = importlib.metadata.version(package)
        except importlib.metadata.PackageNotFoundError:
            versions[package] = "not installed"
    return versions


def _compat_section(plan: StudyPlan) -> list[str]:
    """Why the published code's numbers differ from the text's: one paragraph per switch."""
    if "published" not in plan.compat:
        return []
    lines = [
        "## The published code beside the text",
        "",
        "The `-published` runs switch in, one by one, the behaviours in which the "
        "published reference code (github.com/flyinglightspeck/Swazure) differs from "
        "the paper's text; the paper's Tables 2-4 are that code's output. Table 3's "
        "metric is the total moved per resolved pair (the per-pair columns).",
        "",
    ]
    for name in PUBLISHED.switches_on():
        lines += [f"- `{name}`: {Compat.describe(name)}", ""]
    return lines


def report_markdown(
    plan: StudyPlan,
    result: SweepResult,
    tables: list[Table],
    figures: dict[str, Path],
    out: Path,
) -> str:
    """The one-page report: parameters, software, tables and figures."""
    sensor = plan.sensor
    error_model = (
        "none (accurate)"
        if sensor.accurate
        else "polynomial " + ", ".join(f"{c:g}" for c in sensor.error_coefficients)
    )
    shapes = ", ".join(
        f"{cloud.name} ({len(cloud.points)} FLSs, scale {cloud.scale:g})" for cloud in plan.clouds
    )
    techniques = ", ".join(technique.title for technique in plan.techniques) or "none"
    lines = [
        "# Swazure study",
        "",
        f"Generated {datetime.datetime.now().astimezone():%Y-%m-%d %H:%M %Z} by "
        f"`{' '.join(['swazure', *sys.argv[1:]]) if sys.argv else 'swazure study'}`.",
        "",
        "## Parameters",
        "",
        f"- shapes: {shapes}",
        f"- β: {', '.join(f'{b:g}' for b in plan.betas)}; policies: {', '.join(plan.policies)}",
        f"- heuristics: {techniques}, at β {', '.join(f'{b:g}' for b in plan.heuristic_betas)}"
        f" with {plan.heuristic_policy}",
        f"- sensor {sensor.name} ({plan.sensor_file or 'config/sensor.yaml'}): sweet "
        f"[{sensor.sweet_min:g}, {sensor.sweet_max:g}) cm, decaying "
        f"[{sensor.decaying_min:g}, {sensor.decaying_max:g}) cm, error model {error_model}",
        f"- seed of the choice of colliding FLSs to remove: {plan.seed}",
        f"- runs: {len(result.summaries)} ({result.computed} computed now, {result.cached} "
        f"from earlier results); computation {result.compute_seconds:.1f} s, "
        f"this call {result.wall_seconds:.1f} s",
        "",
        "## Software and machine",
        "",
        ", ".join(f"{name} {version}" for name, version in software_versions().items())
        + f"; {_cpu()}, {os.cpu_count()} cores, {platform.system()} {platform.release()}.",
        "",
        "## Tables",
        "",
        "Each table is also a CSV file in `tables/`; every run's `summary.json` is in "
        "`runs/<shape>/beta-<β>/<policy>/<technique>/`, with its `pairs.parquet` "
        f"({plan.pairs} per-pair columns) {_pairs_kept(plan)}.",
        "",
        tables_markdown(tables),
        *_compat_section(plan),
        "## Figures",
        "",
    ]
    for name, path in figures.items():
        lines += [f"![{name}]({path.relative_to(out).as_posix()})", ""]
    return "\n".join(lines)


def _pairs_kept(plan: StudyPlan) -> str:
    """Which runs kept their per-pair file, for the report's sentence."""
    if plan.keep_pairs:
        return "for every run (--keep-pairs)"
    runs = len(plan.figure_runs())
    return (
        f"for the {runs} runs the figures read only: every other number of the tables and "
        "figures comes from the summaries (`swazure study --keep-pairs` keeps every run's pairs)"
    )


def write_report(
    plan: StudyPlan,
    result: SweepResult,
    tables: list[Table],
    figures: dict[str, Path],
    out: Path,
) -> Path:
    """Write ``report.md`` into ``out``; return its path."""
    return write_text(out / REPORT_FILE, report_markdown(plan, result, tables, figures, out))
