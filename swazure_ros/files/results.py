"""A run's results on disk: ``summary.json`` and the per-pair file, written and read.

The per-pair file is ``pairs.csv`` (the default), ``pairs.parquet`` (typed,
a fraction of the size) or none at all (``--pairs csv|parquet|none``);
:func:`read_pairs` reads either back as one table, and :func:`pairs_size_warning`
says beforehand when one would be large. :func:`write_run` writes a run's
files with its ``record.json`` (:mod:`.record`). Every file is written
atomically (:mod:`.atomic`): a killed run never leaves a half-written result.
"""

from __future__ import annotations

import itertools
import json
import os
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from functools import partial
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..core.errors import OutputError, SwazureError
from ..core.evaluation import REASON_NAMES, STATUS_NAMES, Evaluation, PairResults
from ..core.heuristics.result import HeuristicResult, MovedPairs
from ..core.neighbourhood import Neighbourhood
from ..core.threads import in_order
from .atomic import atomic_output, atomic_write, write_json
from .reading import CONFIG_BYTES, read_text, regular_file
from .record import RECORD_FILE, RunRecord, write_record

PAIRS_FILE = "pairs.csv"
PAIRS_PARQUET_FILE = "pairs.parquet"
SUMMARY_FILE = "summary.json"
PAIRS_FORMATS = ("csv", "parquet")
#: The per-pair output a run may choose: a file of either format, or none.
NO_PAIRS = "none"
PAIRS_OUTPUTS = (*PAIRS_FORMATS, NO_PAIRS)
PAIRS_FILES = {"csv": PAIRS_FILE, "parquet": PAIRS_PARQUET_FILE}
#: Per-pair columns: every one, or only those that nothing else reproduces.
FULL_PAIRS, COMPACT_PAIRS = "full", "compact"
PAIR_COLUMNS = (FULL_PAIRS, COMPACT_PAIRS)
#: What a compact file leaves out: each follows from the columns kept and the swarm
#: (truth and lengths from the positions, hops from the path, angles from estimate
#: and truth, obstruction from line of sight and the policy's S_all path), and the
#: run's summary holds their statistics.
DERIVED_COLUMNS = (
    "hops", "sweet_hops", "decaying_hops", "path_length", "truth_x", "truth_y", "truth_z",
    "theta_deg", "phi_deg", "sweet_path_obstructed", "obstructing_flss",
)  # fmt: skip


#: The columns of an estimate's covariance (least-squares estimator) and their entries.
COVARIANCE_ENTRIES = {
    "covariance_xx": (0, 0), "covariance_xy": (0, 1), "covariance_xz": (0, 2),
    "covariance_yy": (1, 1), "covariance_yz": (1, 2), "covariance_zz": (2, 2),
}  # fmt: skip


def _id_lists(offsets: Any, ids: Any, as_text: bool) -> Any:
    """FLS id lists (offsets (M + 1,), ids): uint32 lists, or ids joined by spaces for CSV."""
    import pyarrow as pa
    import pyarrow.compute as pc

    if not as_text:
        return pa.LargeListArray.from_arrays(pa.array(offsets), pa.array(ids, pa.uint32()))
    # Cast in Arrow: numpy strings of millions of ids would come back chunked.
    text = pc.cast(pa.array(ids, pa.int64()), pa.string())
    return pc.binary_join(pa.LargeListArray.from_arrays(pa.array(offsets), text), " ")


def pairs_table(
    hood: Neighbourhood,
    pairs: PairResults,
    heuristic: HeuristicResult | None = None,
    as_text: bool = True,
    columns: str = FULL_PAIRS,
) -> Any:
    """Per ordered blind pair results as a pyarrow Table; FLS ids are cloud row numbers.

    With ``heuristic`` (or a MovedPairs' own), columns for its moves: tried,
    resolved, number of moves, the FLSs moved, the largest single move, and
    for Move Source the distance flown and the net displacement of the
    source (cm). Paths and
    moved FLSs are uint32 lists, or with ``as_text`` ids joined by spaces (CSV
    has no lists). ``columns="compact"`` leaves out the DERIVED_COLUMNS.
    """
    import pyarrow as pa

    if columns not in PAIR_COLUMNS:
        raise ValueError(f"columns must be one of {PAIR_COLUMNS}, got {columns!r}")
    ids = hood.swarm.cloud_index
    table = {
        "source": ids[pairs.source],
        "target": ids[pairs.target],
        # Names taken in Arrow: a numpy array of millions of strings is slow to convert.
        "status": pa.array(STATUS_NAMES).take(pairs.status),
        "reason": pa.array(REASON_NAMES).take(pairs.reason),
        "hops": pairs.hops,
        "sweet_hops": pairs.sweet_hops,
        "decaying_hops": pairs.decaying_hops,
        "path_length": pairs.path_length,
        "path": _id_lists(pairs.offsets, ids[pairs.nodes], as_text),
        "estimate_x": pairs.estimate[:, 0],
        "estimate_y": pairs.estimate[:, 1],
        "estimate_z": pairs.estimate[:, 2],
        "truth_x": pairs.truth[:, 0],
        "truth_y": pairs.truth[:, 1],
        "truth_z": pairs.truth[:, 2],
        "distance_error_pct": pairs.distance_error,
        "alpha_deg": pairs.alpha,
        "theta_deg": pairs.theta,
        "phi_deg": pairs.phi,
        "sweet_path_obstructed": pairs.sweet_obstructed,
        "obstructing_flss": pairs.obstructing_flss,
        "predicted_error_cm": pairs.predicted_error,
        "fused_paths": pairs.fused_paths,
    }
    if pairs.covariance is not None:
        # The covariance's six distinct entries, cm^2 (core.fit): x, y, z in the swarm's frame.
        for name, (row, column) in COVARIANCE_ENTRIES.items():
            table[name] = pairs.covariance[:, row, column]
    if heuristic is None and isinstance(pairs, MovedPairs):
        heuristic = pairs.heuristic  # a block of a heuristic's run made block by block
    if heuristic is not None:
        counts = np.diff(heuristic.move_offsets)
        moved_ids = _id_lists(heuristic.move_offsets, ids[heuristic.move_fls], as_text)
        owner = np.repeat(np.arange(len(counts)), counts)
        largest = np.zeros(len(counts))
        np.maximum.at(largest, owner, heuristic.move_distance)
        table.update(
            {
                "tried": heuristic.tried,
                "resolved": heuristic.resolved,
                "moves": counts,
                "moved_flss": moved_ids,
                "largest_move": largest,
            }
        )
        if len(heuristic.flown):
            displacement = np.zeros(len(counts))
            displacement[owner] = heuristic.move_distance
            table.update({"flown_distance": heuristic.flown, "displacement": displacement})
    if columns == COMPACT_PAIRS:
        table = {name: value for name, value in table.items() if name not in DERIVED_COLUMNS}
    return pa.table(table)


#: Rows of a table turned into CSV text at a time: about 3 MB of pairs.csv. Slices of
#: 100,000 rows were no faster and held 100-200 MB more at the peak.
CSV_ROWS = 10_000
#: Rows of a Parquet row group: pyarrow's own default, 1024 * 1024.
PARQUET_ROWS = 1024 * 1024
#: Tables of fewer rows are written in one call: threads would save them under 0.2 s
#: and cost 40-50 MB of resident memory (the chess piece: 322 MB against 370 MB).
THREADED_CSV_ROWS = 1_000_000


def write_csv(
    table: Any, out: Path | BinaryIO, threads: int | None = None, header: bool = True
) -> None:
    """Write a pyarrow Table as CSV to ``out``, the same bytes as ``pyarrow.csv.write_csv``.

    ``out``: a path, or a binary file open for writing (a block of a longer
    file, ``header`` False but for the first). Numbers to text is most of a
    large file's time and pyarrow does it on one core: from
    THREADED_CSV_ROWS rows, slices of CSV_ROWS rows are formatted on
    ``threads`` threads (the cores this process may use) and written in row
    order, at most one slice per thread ahead of the file, so that memory
    stays bounded.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    if isinstance(out, Path):
        with open(out, "wb") as file:
            write_csv(table, file, threads, header)
        return

    def text(start: int) -> Any:
        sink = pa.BufferOutputStream()
        options = pacsv.WriteOptions(include_header=header and start == 0)
        pacsv.write_csv(table.slice(start, CSV_ROWS), sink, options)
        return sink.getvalue()

    threads = threads or len(os.sched_getaffinity(0))
    if table.num_rows < THREADED_CSV_ROWS or threads == 1:
        pacsv.write_csv(table, out, pacsv.WriteOptions(include_header=header))
        return
    starts = range(0, max(table.num_rows, 1), CSV_ROWS)  # an empty table has its header
    with ThreadPoolExecutor(threads) as pool:
        for text_of_slice in in_order(pool, text, starts, threads + 1):
            out.write(text_of_slice)


def write_evaluation(
    directory: Path,
    evaluation: Evaluation,
    heuristic: HeuristicResult | None = None,
    pairs_format: str = "csv",
    columns: str = FULL_PAIRS,
) -> tuple[Path, Path | None]:
    """Write ``summary.json`` and the per-pair file into ``directory``; return their paths.

    The per-pair file is ``pairs.csv``, or with ``pairs_format="parquet"`` a
    zstd-compressed ``pairs.parquet`` (typed, paths as integer lists, a
    fraction of the size), or with ``"none"`` no file (its path None);
    ``columns`` as :func:`pairs_table`. The summary is written last, so its
    presence means the run is complete. A per-pair file of another output
    left in ``directory`` by an earlier run is removed: it is not this run's.
    """
    _check_pairs_output(pairs_format)
    pairs_path = None
    if pairs_format != NO_PAIRS:
        table = pairs_table(
            evaluation.hood, evaluation.pairs, heuristic, pairs_format == "csv", columns
        )
        pairs_path = directory / PAIRS_FILES[pairs_format]
        atomic_write(pairs_path, partial(_write_table, table, pairs_format))
    _remove_other_pairs(directory, pairs_format)
    summary_path = directory / SUMMARY_FILE
    write_json(summary_path, evaluation.summary.as_document())
    return summary_path, pairs_path


def _remove_other_pairs(directory: Path, pairs_format: str) -> None:
    """Remove the per-pair files of the outputs other than ``pairs_format`` from ``directory``."""
    for other, name in PAIRS_FILES.items():
        if other != pairs_format:
            try:
                (directory / name).unlink(missing_ok=True)
            except OSError as err:
                raise OutputError(
                    f"{directory / name}: cannot remove ({err.strerror or err})"
                ) from err


def _check_pairs_output(pairs_format: str) -> None:
    if pairs_format not in PAIRS_OUTPUTS:
        raise ValueError(f"pairs_format must be one of {PAIRS_OUTPUTS}, got {pairs_format!r}")


def _write_table(table: Any, pairs_format: str, path: Path) -> None:
    """Write a whole pairs table to ``path`` as CSV or Parquet."""
    if pairs_format == "csv":
        write_csv(table, path)
        return
    import pyarrow.parquet as pq

    pq.write_table(table, str(path), compression="zstd", row_group_size=PARQUET_ROWS)


def write_pair_blocks(
    directory: Path,
    hood: Neighbourhood,
    policy: str,
    blocks: Iterable[PairResults],
    pairs_format: str = "csv",
    columns: str = FULL_PAIRS,
    heuristic: HeuristicResult | None = None,
) -> Path | None:
    """Write the per-pair file of a run made block by block (core.blocks), as blocks come.

    The same bytes as :func:`write_evaluation` gives for the pairs of all
    blocks at once. CSV's table and text are made and written on a thread of
    its own while the next block is made (numpy and pyarrow without the
    GIL), so a block's pairs and table are held while the next block is
    made, and no more. Returns its path; with ``pairs_format="none"`` the
    blocks are only made, and None.
    A heuristic's run held whole comes as one block, with its moves (``heuristic``); one
    made block by block brings each block's moves in its pairs (``MovedPairs``).
    """
    _check_pairs_output(pairs_format)
    if pairs_format == NO_PAIRS:
        for _ in blocks:
            pass
        _remove_other_pairs(directory, pairs_format)
        return None
    path = directory / PAIRS_FILES[pairs_format]
    with atomic_output(path) as temporary:
        if pairs_format == "csv":
            with open(temporary, "wb") as out:
                _write_csv_blocks(
                    blocks, partial(pairs_table, hood, heuristic=heuristic, columns=columns), out
                )
        else:
            import pyarrow.parquet as pq  # here: 0.1 s of a run that writes CSV

            tables = (pairs_table(hood, pairs, heuristic, False, columns) for pairs in blocks)
            first = next(tables)
            with pq.ParquetWriter(str(temporary), first.schema, compression="zstd") as writer:
                for group in _row_groups(itertools.chain([first], tables), PARQUET_ROWS):
                    writer.write_table(group, row_group_size=PARQUET_ROWS)
    _remove_other_pairs(directory, pairs_format)
    return path


def _write_csv_blocks(
    blocks: Iterable[PairResults], table_of: Callable[[PairResults], Any], out: BinaryIO
) -> None:
    """Write the tables ``table_of`` makes of ``blocks`` as one CSV to ``out``, each block's
    while the next is made.

    One writer thread: a block's table is made, formatted and written while
    the caller's generator makes the next block, and the next waits for it,
    so at most two blocks are held and the rows stay in order. Making the
    table there too takes its paths' text (most of its time) off the thread
    that makes the blocks. An error of either side is raised here.
    """

    def write(pairs: PairResults, header: bool) -> None:
        write_csv(table_of(pairs), out, None, header)

    with ThreadPoolExecutor(1, thread_name_prefix="pairs-csv") as writer:
        writing: Future[None] | None = None
        for number, pairs in enumerate(blocks):
            if writing is not None:
                writing.result()
            writing = writer.submit(write, pairs, number == 0)
        if writing is not None:
            writing.result()


def _row_groups(tables: Iterator[Any], rows: int) -> Iterator[Any]:
    """The rows of pyarrow ``tables`` as tables of ``rows`` rows (the last fewer), one chunk each.

    What ``pyarrow.parquet.write_table`` cuts a whole table into: so that a
    file written block by block has its row groups, and its bytes.
    """
    import pyarrow as pa

    pending: list[Any] = []
    held, written = 0, False
    for table in tables:
        pending.append(table)
        held += table.num_rows
        while held >= rows:
            joined = pa.concat_tables(pending)
            yield joined.slice(0, rows).combine_chunks()
            written = True
            pending, held = [joined.slice(rows)], held - rows
    if held or not written:
        yield pa.concat_tables(pending).combine_chunks()


#: Per-pair columns that are not float64 (every other one is a length, an error, an angle,
#: a covariance: pairs_table). The id lists are text in CSV, uint32 lists in Parquet.
_INTEGER_COLUMNS = ("source", "target", "hops", "sweet_hops", "decaying_hops",
                    "obstructing_flss", "fused_paths", "moves")  # fmt: skip
_TEXT_COLUMNS = ("status", "reason")
_BOOLEAN_COLUMNS = ("sweet_path_obstructed", "tried", "resolved")
ID_LIST_COLUMNS = ("path", "moved_flss")


def read_pairs(directory: Path, columns: Iterable[str] | None = None) -> Any:
    """The per-pair table of the run in ``directory``, from pairs.parquet or pairs.csv.

    Either file gives the same pyarrow Table: the columns and types
    :func:`pairs_table` makes for Parquet (id lists as uint32 lists), or only
    ``columns``. Raises SwazureError in one line when the folder holds
    neither file, saying so when the run chose to write none.
    """
    columns = None if columns is None else list(columns)
    parquet, csv = directory / PAIRS_PARQUET_FILE, directory / PAIRS_FILE
    if parquet.exists():
        import pyarrow.parquet as pq

        regular_file(parquet, "per-pair", None, SwazureError)
        return pq.read_table(parquet, columns=columns)
    if csv.exists():
        return _read_pairs_csv(regular_file(csv, "per-pair", None, SwazureError), columns)
    raise SwazureError(
        f"{directory}: no {PAIRS_FILE} or {PAIRS_PARQUET_FILE}{_why_none(directory)}"
    )


def _why_none(directory: Path) -> str:
    """Why a run's folder holds no per-pair file, when its record or summary says it chose so."""
    for name, keys, reason in (
        (RECORD_FILE, ("pairs",), "the run was made with --pairs none"),
        (SUMMARY_FILE, ("study", "pairs"), "the study kept no pairs of this run "
         "(swazure study --keep-pairs keeps every run's)"),
    ):  # fmt: skip
        try:
            value: Any = json.loads(read_text(directory / name, "", CONFIG_BYTES, SwazureError))
            for key in keys:
                value = value.get(key) if isinstance(value, dict) else None
        except (SwazureError, ValueError):
            continue
        if value == NO_PAIRS:
            return f": {reason}"
    return ""


def _read_pairs_csv(path: Path, columns: list[str] | None) -> Any:
    """A pairs.csv as the table its pairs.parquet would hold (no value is null in either)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv

    with open(path, "rb") as file:
        header = file.readline().decode("utf-8", "replace").strip()
    names = [name.strip('"') for name in header.split(",")] if header else []
    wanted = names if columns is None else columns
    types = {name: _csv_type(name) for name in names}
    options = pacsv.ConvertOptions(
        column_types=types, include_columns=wanted, null_values=[], strings_can_be_null=False
    )
    try:
        table = pacsv.read_csv(path, convert_options=options)
    except (pa.ArrowInvalid, KeyError) as err:
        raise SwazureError(f"{path}: not a per-pair file ({err})") from err
    for name in ID_LIST_COLUMNS:
        if name in table.column_names:
            index = table.column_names.index(name)
            table = table.set_column(index, name, _id_list(table.column(name)))
    return table


def _csv_type(name: str) -> Any:
    import pyarrow as pa

    if name in _INTEGER_COLUMNS:
        return pa.int64()
    if name in _BOOLEAN_COLUMNS:
        return pa.bool_()
    if name in _TEXT_COLUMNS or name in ID_LIST_COLUMNS:
        return pa.string()
    return pa.float64()


def _id_list(text: Any) -> Any:
    """FLS ids joined by spaces (CSV) as uint32 lists, an empty text an empty list."""
    import pyarrow as pa
    import pyarrow.compute as pc

    text = text.combine_chunks()
    lengths = np.asarray(pc.utf8_length(text), dtype=np.int64)
    counts = np.where(lengths > 0, np.asarray(pc.count_substring(text, " ")) + 1, 0)
    offsets = np.concatenate([[0], np.cumsum(counts)])
    ids = pc.split_pattern(text, " ").flatten()
    ids = ids.filter(pc.greater(pc.utf8_length(ids), 0))
    return pa.LargeListArray.from_arrays(pa.array(offsets), pc.cast(ids, pa.uint32()))


#: Bytes a per-pair row takes, about, in each format: plain Swazure, every column, at the
#: top of what was measured (beta 0.5; 2026-11-29): pairs.csv 281 bytes a pair for the race
#: car, 286 for torus:10000, 304 for torus:65536 (6.05 GB); pairs.parquet (zstd) 99, 54
#: and 72 (1.43 GB). A heuristic's or a fit's columns add to them.
PAIR_ROW_BYTES = {"csv": 310, "parquet": 100, NO_PAIRS: 0}
#: A run says how much it will write before a per-pair file larger than this.
LARGE_PAIRS_BYTES = 10**9
#: The environment variable that sets another limit, bytes (a test's small one).
LARGE_PAIRS_VARIABLE = "SWAZURE_LARGE_PAIRS_BYTES"


def pairs_bytes(pairs: int, pairs_format: str) -> int:
    """About how many bytes the per-pair file of ``pairs`` ordered blind pairs takes.

    Parameters
    ----------
    pairs : int
        Ordered blind pairs, one row each.
    pairs_format : str
        ``csv``, ``parquet`` or ``none`` (PAIRS_OUTPUTS).

    Returns
    -------
    int
        Bytes, from the measured bytes per row (PAIR_ROW_BYTES); 0 for none.

    Examples
    --------
    >>> round(pairs_bytes(19_927_398, "csv") / 1e9, 1)  # torus:65536, 6.05 GB written
    6.2
    """
    _check_pairs_output(pairs_format)
    if pairs < 0:
        raise ValueError(f"pairs must be at least 0, got {pairs}")
    return pairs * PAIR_ROW_BYTES[pairs_format]


def large_pairs_limit() -> int:
    """LARGE_PAIRS_BYTES, or the bytes $SWAZURE_LARGE_PAIRS_BYTES gives (SwazureError if
    it is not a whole number)."""
    text = os.environ.get(LARGE_PAIRS_VARIABLE, "").strip()
    if not text:
        return LARGE_PAIRS_BYTES
    try:
        return int(text)
    except ValueError as err:
        raise SwazureError(
            f"${LARGE_PAIRS_VARIABLE}: {text!r} is not a whole number of bytes"
        ) from err


def pairs_size_warning(
    pairs: int, pairs_format: str, limit: int = LARGE_PAIRS_BYTES
) -> str | None:
    """One line saying how much the per-pair file will take, when more than ``limit`` bytes.

    It names the smaller outputs (``--pairs parquet``, ``--pairs none``) and
    what they take; None for a file within the limit.
    """
    size = pairs_bytes(pairs, pairs_format)
    if size <= limit:
        return None
    smaller = [
        f"--pairs {other} "
        + (
            f"about {_size(pairs_bytes(pairs, other))}"
            if other != NO_PAIRS
            else "no per-pair file"
        )
        for other in PAIRS_OUTPUTS
        if pairs_bytes(pairs, other) < size
    ]
    return (
        f"{PAIRS_FILES[pairs_format]} will take about {_size(size)} "
        f"({pairs:,} pairs at about {PAIR_ROW_BYTES[pairs_format]} bytes each); "
        f"{' or '.join(smaller)}"
    )


def _size(size: int) -> str:
    """Bytes for people: GB with a decimal from 1 GB, whole MB below."""
    return f"{size / 1e9:.1f} GB" if size >= 10**9 else f"{size / 1e6:.0f} MB"


def write_run(
    directory: Path,
    evaluation: Evaluation,
    record: RunRecord,
    heuristic: HeuristicResult | None = None,
) -> tuple[Path, Path | None, Path]:
    """Write a run's ``summary.json``, per-pair file and ``record.json`` into ``directory``.

    The per-pair file is the one ``record.pairs`` names (csv when it names
    none, None when it is "none"). Returns the three paths; one-line
    OutputError when the folder cannot take them.
    """
    try:
        summary, pairs = write_evaluation(directory, evaluation, heuristic, record.pairs or "csv")
        return summary, pairs, write_record(directory, record)
    except OutputError:
        raise
    except OSError as err:
        raise OutputError(f"{directory}: cannot write results ({err.strerror or err})") from err
