"""A run's output folder read back, and runs compared from their folders (``swazure compare``).

A run folder is what ``swazure evaluate --out`` or ``swazure spawn --out``
writes: ``summary.json`` (read into :class:`~swazure_ros.core.summary.Summary`),
the per-pair file (``pairs.csv`` or ``pairs.parquet``, or none) and
``record.json``. :func:`compare_runs` reads two or more and compares them
(core.compare); :func:`write_comparison` writes the comparison as JSON and CSV.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.compare import Comparison, check_one_cloud, cloud_of, compare
from ..core.errors import SwazureError
from ..core.evaluation import REASON_NAMES
from ..core.metric_rows import MetricRow
from ..core.pair_classes import ErrorUnit, PairErrors
from ..core.summary import Summary
from .atomic import atomic_write, write_json
from .reading import CONFIG_BYTES, read_text
from .results import PAIRS_FILE, PAIRS_PARQUET_FILE, SUMMARY_FILE

COMPARISON_JSON = "comparison.json"
COMPARISON_CSV = "comparison.csv"
ESTIMATE_COLUMNS = ("estimate_x", "estimate_y", "estimate_z")
TRUTH_COLUMNS = ("truth_x", "truth_y", "truth_z")
#: Bytes of a per-pair CSV parsed at a time: the file is read a block at a time, and only
#: a pair's class and error are kept (9 bytes a pair), so a file of many GB fits.
CSV_BLOCK = 16 * 2**20


@dataclass(frozen=True)
class RunFolder:
    """A run's output folder: its summary and its per-pair file (None: it has none)."""

    folder: Path
    summary: Summary
    pairs: Path | None


def read_summary(path: Path) -> Summary:
    """The summary in ``path`` (a run's summary.json); SwazureError in one line if not one."""
    text = read_text(path, "summary", CONFIG_BYTES, SwazureError)
    try:
        return Summary.from_document(json.loads(text))
    except (AttributeError, KeyError, TypeError, ValueError) as err:
        # Not JSON, or a field missing or of the wrong kind: not what this reads.
        raise SwazureError(f"{path}: not a run's summary ({type(err).__name__}: {err})") from err


def read_run(folder: Path) -> RunFolder:
    """The run in ``folder``; SwazureError in one line if it is not a run's output folder."""
    if not folder.is_dir():
        what = "no such folder" if not folder.exists() else "not a folder"
        raise SwazureError(f"{folder}: not a run folder ({what})")
    if not (folder / SUMMARY_FILE).exists():
        raise SwazureError(
            f"{folder}: not a run folder: no {SUMMARY_FILE} (swazure evaluate --out DIR and "
            "swazure spawn --compute-all --out DIR write one)"
        )
    summary = read_summary(folder / SUMMARY_FILE)
    names = (PAIRS_FILE, PAIRS_PARQUET_FILE)
    pairs = next((folder / name for name in names if (folder / name).is_file()), None)
    return RunFolder(folder, summary, pairs)


def pair_columns(path: Path) -> list[str]:
    """The column names of a per-pair file (its header, or its Parquet schema)."""
    try:
        if path.suffix == ".parquet":
            import pyarrow.parquet as pq

            return list(pq.read_schema(path).names)
        with open(path, newline="") as file:
            return next(csv.reader(io.StringIO(file.readline())), [])
    except (OSError, ValueError) as err:
        raise SwazureError(f"{path}: not a per-pair file ({err})") from err


def _batches(path: Path, columns: list[str]) -> Iterator[Any]:
    """The ``columns`` of a per-pair file as pyarrow record batches, a block at a time."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    if path.suffix == ".parquet":
        yield from pq.ParquetFile(path).iter_batches(columns=columns)
        return
    convert = pacsv.ConvertOptions(include_columns=columns, column_types={"reason": pa.string()})
    with pacsv.open_csv(path, pacsv.ReadOptions(block_size=CSV_BLOCK), None, convert) as reader:
        yield from reader


def read_pair_errors(path: Path, unit: ErrorUnit) -> PairErrors:
    """Each pair's class (its reason's code) and its error from a per-pair file.

    ``unit`` "cm": the position error |estimate - truth|; "%": the distance error.
    A pair without an estimate has a NaN error. SwazureError in one line when the
    file is not a per-pair table.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    wanted = [*ESTIMATE_COLUMNS, *TRUTH_COLUMNS] if unit == "cm" else ["distance_error_pct"]
    classes, errors = [], []
    known = pa.array(REASON_NAMES)
    try:
        for batch in _batches(path, ["reason", *wanted]):
            code = pc.index_in(batch.column("reason").cast(pa.string()), value_set=known)
            if code.null_count:
                raise SwazureError(f"{path}: a pair's reason is none of {REASON_NAMES}")
            classes.append(code.to_numpy().astype(np.uint8))
            values = [batch.column(name).to_numpy(zero_copy_only=False) for name in wanted]
            if unit == "cm":
                estimate, truth = np.column_stack(values[:3]), np.column_stack(values[3:])
                errors.append(np.linalg.norm(estimate - truth, axis=1))
            else:
                errors.append(np.asarray(values[0], dtype=np.float64))
    except (pa.ArrowException, KeyError, OSError, ValueError, TypeError) as err:
        raise SwazureError(f"{path}: not a per-pair table ({err})") from err
    if not classes:
        return PairErrors(np.zeros(0, np.uint8), np.zeros(0), unit)
    return PairErrors(np.concatenate(classes), np.concatenate(errors).astype(np.float64), unit)


def run_labels(folders: Sequence[Path]) -> list[str]:
    """Each run's label: its folder's name, or its path as given where two names are one."""
    names = [folder.resolve().name for folder in folders]
    return [
        name if names.count(name) == 1 else str(folder)
        for name, folder in zip(names, folders, strict=True)
    ]


def compare_runs(folders: Sequence[Path]) -> Comparison:
    """The runs in ``folders`` side by side (core.compare), the first the reference.

    Runs are labelled by their folder's name. Their errors are position errors
    in cm when every per-pair file has the truth, else distance errors in %.
    SwazureError in one line: fewer than two runs, a folder given twice or not a
    run's, runs of different clouds.
    """
    if len(folders) < 2:
        raise SwazureError(f"compare needs two or more runs, got {len(folders)}")
    resolved = [folder.resolve() for folder in folders]
    twice = sorted(
        {str(f) for f, r in zip(folders, resolved, strict=True) if resolved.count(r) > 1}
    )
    if twice:
        raise SwazureError(f"a run given twice: {', '.join(twice)}")
    runs = [read_run(folder) for folder in folders]
    labels = run_labels(folders)
    # Before the per-pair files, which may be large: runs of two clouds do not compare.
    check_one_cloud(labels, [run.summary for run in runs])
    with_pairs = [run.pairs for run in runs if run.pairs is not None]
    truth = all(set(TRUTH_COLUMNS) <= set(pair_columns(pairs)) for pairs in with_pairs)
    unit: ErrorUnit = "cm" if truth else "%"
    return compare(
        [
            (label, run.summary, None if run.pairs is None else read_pair_errors(run.pairs, unit))
            for label, run in zip(labels, runs, strict=True)
        ]
    )


def _row_document(row: MetricRow, labels: Sequence[str]) -> dict[str, Any]:
    return {
        "row": row.label,
        "better": row.better,
        "values": dict(zip(labels, row.values, strict=True)),
        "deltas": dict(zip(labels, row.deltas, strict=True)),
        "best": [labels[i] for i in row.best],
        "margin": row.margin,
        "why_none": dict(zip(labels, row.why_none, strict=True)),
    }


def comparison_document(comparison: Comparison) -> dict[str, Any]:
    """What ``comparison.json`` holds: the runs and their results by class (with their
    error distributions), the rows with values, deltas and best, and the verdicts."""
    labels = [run.label for run in comparison.runs]
    return {
        "error_unit": comparison.error_unit,
        "runs": [
            {
                "label": run.label,
                "method": run.method,
                "cloud": cloud_of(run.summary),
                "classes": None if run.classes is None else [asdict(c) for c in run.classes],
            }
            for run in comparison.runs
        ],
        "rows": [_row_document(row, labels) for row in comparison.rows],
        "class_rows": [_row_document(row, labels) for row in comparison.class_rows],
        "verdicts": [
            {
                "pair_class": verdict.pair_class,
                "by_median": [[labels[i] for i in group] for group in verdict.by_median],
                "by_coverage": [[labels[i] for i in group] for group in verdict.by_coverage],
                "statement": verdict.statement,
            }
            for verdict in comparison.verdicts
        ],
    }


def _write_csv(path: Path, comparison: Comparison) -> None:
    labels = [run.label for run in comparison.runs]
    text = io.StringIO()
    out = csv.writer(text, lineterminator="\n")
    out.writerow(["row", "better", *labels, *(f"delta {label}" for label in labels[1:]), "best"])
    for row in (*comparison.rows, *comparison.class_rows):
        numbers = [*row.values, *row.deltas[1:]]
        best = " ".join(labels[i] for i in row.best)
        out.writerow(
            [row.label, row.better, *("" if v is None else repr(v) for v in numbers), best]
        )
    atomic_write(path, lambda tmp: tmp.write_text(text.getvalue()))


def write_comparison(folder: Path, comparison: Comparison) -> tuple[Path, Path]:
    """Write ``comparison.json`` and ``comparison.csv`` (one line per row: each run's value,
    its delta from the first run's, the best runs) into ``folder``, atomically."""
    json_path, csv_path = folder / COMPARISON_JSON, folder / COMPARISON_CSV
    write_json(json_path, comparison_document(comparison))
    _write_csv(csv_path, comparison)
    return json_path, csv_path
