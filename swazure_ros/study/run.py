"""A whole study: compute the missing runs, then write tables, figures and the report."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .figures import study_figures, study_snapshots
from .plan import StudyPlan
from .report import write_report, write_tables
from .sweep import SweepProgress, SweepResult, sweep
from .tables import Table, study_tables


@dataclass
class StudyOutputs:
    """What a study wrote, and the sweep behind it."""

    result: SweepResult
    tables: list[Table]
    tables_path: Path
    figures: dict[str, Path]
    report_path: Path


def run_study(
    plan: StudyPlan, out: Path, jobs: int = 1, progress: SweepProgress | None = None
) -> StudyOutputs:
    """Bring ``out`` up to date with ``plan``: runs, tables, figures and report."""
    result = sweep(plan, out, jobs, progress)
    tables = study_tables(plan, result)
    tables_path = write_tables(out, tables)
    figures = study_figures(plan, result, out)
    figures.update(study_snapshots(plan, out))
    report_path = write_report(plan, result, tables, figures, out)
    return StudyOutputs(result, tables, tables_path, figures, report_path)
