"""A run's results: summary.json and the per-pair file written whole, read back as one table."""

import numpy as np
import pytest

from swazure_ros.core.errors import OutputError, SwazureError
from swazure_ros.files.record import RunRecord, read_record

from ..conftest import SCENE


def test_a_run_that_cannot_be_written_is_one_line_and_leaves_nothing(tmp_path, sensor):
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.files.results import write_run

    evaluation = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    with pytest.raises(OutputError) as raised:
        write_run(blocker, evaluation, RunRecord("evaluate", 0.1, evaluation.summary))
    assert "\n" not in str(raised.value)
    assert blocker.read_text() == "not a folder"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["a-file"]


@pytest.mark.parametrize("rows", [0, 1, 7, 30])
@pytest.mark.parametrize("threads", [1, 3])
def test_csv_written_slice_by_slice_on_threads_is_pyarrows_own_bytes(
    tmp_path, monkeypatch, rows, threads
):
    import pyarrow as pa
    import pyarrow.csv as pacsv

    from swazure_ros.files import results

    # Slices of 4 rows: 30 rows are 8 slices, more than the threads keep in flight.
    monkeypatch.setattr(results, "CSV_ROWS", 4)
    monkeypatch.setattr(results, "THREADED_CSV_ROWS", 0)
    values = np.random.default_rng(0).normal(size=rows)
    table = pa.table(
        {
            "source": np.arange(rows),
            "status": pa.array(["SWEET", "NO_PATH"]).take(np.arange(rows) % 2),
            "path": [" ".join(map(str, range(row % 4))) for row in range(rows)],
            "estimate_x": values,
            "obstructed": values > 0,
        }
    )
    pacsv.write_csv(table, str(tmp_path / "whole.csv"))
    results.write_csv(table, tmp_path / "sliced.csv", threads)
    expected = (tmp_path / "whole.csv").read_bytes()
    assert (tmp_path / "sliced.csv").read_bytes() == expected
    assert expected.count(b"\n") == rows + 1


@pytest.mark.parametrize("pairs_format", ["csv", "parquet"])
def test_pairs_written_block_by_block_are_the_bytes_of_the_pairs_written_at_once(
    tmp_path, monkeypatch, sensor, pairs_format
):
    from swazure_ros.core.blocks import Budget, evaluate_blocked
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.core.progress import SILENT
    from swazure_ros.files import results
    from swazure_ros.files.cloud_files import load_cloud
    from swazure_ros.files.results import write_evaluation, write_pair_blocks

    # Row groups of 1,000 pairs: the blocks' boundaries fall inside them.
    monkeypatch.setattr(results, "PARQUET_ROWS", 1000)
    swarm = make_swarm(load_cloud("helix:200").points, beta=0.5)
    whole, blocked = tmp_path / "whole", tmp_path / "blocked"
    whole.mkdir(), blocked.mkdir()
    _, expected = write_evaluation(
        whole, evaluate(swarm, sensor, "fewest-hops"), None, pairs_format
    )
    run = evaluate_blocked(swarm, sensor, "fewest-hops", Budget(2**20), SILENT)
    assert len(run.sources()) > 1
    got = write_pair_blocks(blocked, run.hood, run.policy, run.blocks(SILENT), pairs_format)
    assert got.read_bytes() == expected.read_bytes()
    assert not list(blocked.glob(".*"))  # no temporary file left behind


def test_a_blocks_csv_table_is_made_on_the_writer_thread_not_the_one_making_blocks(
    tmp_path, monkeypatch, sensor
):
    import threading

    from swazure_ros.core.blocks import Budget, evaluate_blocked
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.core.progress import SILENT
    from swazure_ros.files import results
    from swazure_ros.files.cloud_files import load_cloud

    made_on, blocks_on = [], []
    real_table = results.pairs_table

    def spy_table(*args, **kwargs):
        made_on.append(threading.current_thread().name)
        return real_table(*args, **kwargs)

    def spy_blocks(blocks):
        for pairs in blocks:
            blocks_on.append(threading.current_thread().name)
            yield pairs

    monkeypatch.setattr(results, "pairs_table", spy_table)
    run = evaluate_blocked(
        make_swarm(load_cloud("helix:200").points, beta=0.5),
        sensor,
        "fewest-hops",
        Budget(2**20),
        SILENT,
    )
    results.write_pair_blocks(tmp_path, run.hood, run.policy, spy_blocks(run.blocks(SILENT)))
    assert len(made_on) == len(blocks_on) == len(run.sources()) > 1
    # The paths' text, most of a table's time, is not made between one block and the next.
    assert set(blocks_on) == {threading.current_thread().name}
    assert all(name.startswith("pairs-csv") for name in made_on)


#: sha256 of torus:200's pairs.csv at beta 0.5, shortest-length, its real columns rounded
#: to 6 decimals (_rounded), as main wrote it at 685ba2b. The whole file's hash was pinned
#: at 36557f7 (b9f5309c...); on the machine of 2026-12-01 main's own 685ba2b wrote other
#: last bits (1fd4d40c...), the same numba, numpy and pyarrow: a real's last bits follow
#: the machine, its first fifteen digits the code.
TORUS_200_PAIRS = "e00109f605c1b58d9198d37de69ca3b8ca22d5da03f3e298cc689d22e859e2bd"


def _rounded(path):
    """The CSV bytes of the table at ``path`` with every real column rounded to 6 decimals."""
    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.csv as pacsv

    table = pacsv.read_csv(path)
    columns = [
        pc.round(column, 6) if pa.types.is_floating(column.type) else column
        for column in table.columns
    ]
    sink = pa.BufferOutputStream()
    pacsv.write_csv(pa.table(columns, names=table.column_names), sink)
    return sink.getvalue().to_pybytes()


def test_a_small_torus_pairs_csv_is_byte_for_byte_the_one_main_wrote(tmp_path):
    import hashlib

    from swazure_ros.core.blocks import Budget, evaluate_blocked
    from swazure_ros.core.progress import SILENT
    from swazure_ros.files.results import write_pair_blocks
    from swazure_ros.sim.world import WorldSpec

    world = WorldSpec("torus:200", beta=0.5).build()
    # Blocks of a few thousand pairs: the writer thread formats one while the next is made.
    run = evaluate_blocked(world.swarm, world.sensor, "shortest-length", Budget(8 * 2**20), SILENT)
    assert len(run.sources()) > 2
    path = write_pair_blocks(tmp_path, run.hood, run.policy, run.blocks(SILENT))
    assert hashlib.sha256(_rounded(path)).hexdigest() == TORUS_200_PAIRS


def _runs(sensor):
    """Plain Swazure, Move Source's moves and a least-squares fit of one small swarm."""
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.fit import refine
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.core.heuristics.compat import COMPAT_MODES
    from swazure_ros.core.heuristics.folding import run_technique
    from swazure_ros.files.cloud_files import load_cloud

    plain = evaluate(make_swarm(load_cloud("torus:200").points, beta=0.5), sensor, "fewest-hops")
    moved, heuristic = run_technique(plain, "move-source", 2, COMPAT_MODES["text"])
    return {
        "plain": (plain, None),
        "move-source": (moved, heuristic),
        "fit": (refine(plain), None),
    }


def same_table(one, other):
    """Two pyarrow tables alike column for column: names, types, values (NaN equal to NaN)."""
    assert one.schema == other.schema
    for name in one.column_names:
        left, right = one.column(name).to_pylist(), other.column(name).to_pylist()
        if one.schema.field(name).type == "double":
            np.testing.assert_array_equal(np.array(left), np.array(right), err_msg=name)
        else:
            assert left == right, name


@pytest.mark.parametrize("run", ["plain", "move-source", "fit"])
def test_pairs_read_back_from_csv_and_from_parquet_are_one_table(tmp_path, sensor, run):
    import pyarrow as pa

    from swazure_ros.files.results import pairs_table, read_pairs, write_evaluation

    evaluation, heuristic = _runs(sensor)[run]
    tables = {}
    for pairs_format in ("csv", "parquet"):
        folder = tmp_path / pairs_format
        folder.mkdir()
        _, path = write_evaluation(folder, evaluation, heuristic, pairs_format)
        assert path.name == f"pairs.{pairs_format}"
        tables[pairs_format] = read_pairs(folder)
    # The table as made, with its id lists: what either file reads back as.
    made = pairs_table(evaluation.hood, evaluation.pairs, heuristic, as_text=False)
    assert made.num_rows > 100 and pa.types.is_large_list(made.schema.field("path").type)
    assert np.isnan(made.column("distance_error_pct").to_numpy()).any()  # pairs without a path
    same_table(tables["csv"], made)
    same_table(tables["parquet"], made)
    some = read_pairs(tmp_path / "csv", ["distance_error_pct", "path"])
    assert some.column_names == ["distance_error_pct", "path"]
    same_table(some, made.select(["distance_error_pct", "path"]))


def test_a_run_that_writes_no_pairs_writes_its_summary_and_says_why_there_are_none(
    tmp_path, sensor
):
    from swazure_ros.files.results import read_pairs, write_evaluation, write_run

    evaluation, _ = _runs(sensor)["plain"]
    summary, pairs = write_evaluation(tmp_path / "bare", evaluation, None, "none")
    assert pairs is None and summary.is_file()
    assert sorted(path.name for path in (tmp_path / "bare").iterdir()) == ["summary.json"]
    with pytest.raises(SwazureError, match=r"no pairs\.csv or pairs\.parquet$"):
        read_pairs(tmp_path / "bare")
    record = RunRecord("evaluate", 0.1, evaluation.summary, pairs="none")
    summary, pairs, written = write_run(tmp_path / "run", evaluation, record)
    assert pairs is None and read_record(written).pairs == "none"
    assert sorted(path.name for path in (tmp_path / "run").iterdir()) == [
        "record.json", "summary.json",
    ]  # fmt: skip
    with pytest.raises(SwazureError, match="made with --pairs none"):
        read_pairs(tmp_path / "run")


@pytest.mark.parametrize(("before", "after"), [("csv", "none"), ("parquet", "csv")])
def test_a_run_written_over_another_leaves_no_per_pair_file_of_the_other(
    tmp_path, sensor, before, after
):
    """A folder holds one run: pairs of an earlier run in another output are not its."""
    from swazure_ros.files.results import write_evaluation

    evaluation, _ = _runs(sensor)["plain"]
    write_evaluation(tmp_path, evaluation, None, before)
    write_evaluation(tmp_path, evaluation, None, after)
    left = sorted(path.name for path in tmp_path.iterdir())
    assert left == sorted(["summary.json"] + ([] if after == "none" else [f"pairs.{after}"]))


def test_the_size_of_a_per_pair_file_is_estimated_from_its_pairs_and_format():
    from swazure_ros.files.results import pairs_bytes

    # torus:65536 at beta 0.5 wrote 19,927,398 pairs in a 6.05 GB pairs.csv (BENCHMARKS.md).
    assert pairs_bytes(19_927_398, "csv") == pytest.approx(6.05e9, rel=0.1)
    # The race car's pairs.parquet: 205 MB for 2,070,164 pairs (2026-11-29).
    assert pairs_bytes(2_070_164, "parquet") == pytest.approx(205e6, rel=0.1)
    assert pairs_bytes(2_070_164, "none") == 0 and pairs_bytes(0, "csv") == 0
    with pytest.raises(ValueError, match="pairs_format must be one of"):
        pairs_bytes(10, "xml")
    with pytest.raises(ValueError, match="at least 0"):
        pairs_bytes(-1, "csv")


def test_a_large_per_pair_file_is_announced_with_the_smaller_outputs(monkeypatch):
    from swazure_ros.files.results import (
        LARGE_PAIRS_BYTES,
        large_pairs_limit,
        pairs_size_warning,
    )

    assert LARGE_PAIRS_BYTES == 10**9
    assert pairs_size_warning(3_000_000, "csv") is None  # 0.9 GB
    assert pairs_size_warning(19_927_398, "none") is None
    line = pairs_size_warning(19_927_398, "csv")
    assert line.startswith("pairs.csv will take about 6.2 GB (19,927,398 pairs at about")
    assert "--pairs parquet about 2.0 GB or --pairs none no per-pair file" in line
    line = pairs_size_warning(19_927_398, "parquet")
    assert line.startswith("pairs.parquet will take about 2.0 GB")
    assert line.endswith("--pairs none no per-pair file") and "--pairs csv" not in line
    assert pairs_size_warning(100, "csv", limit=1000).startswith("pairs.csv will take")
    assert "\n" not in line
    # The limit from the environment: a test's small one, or a clear error.
    monkeypatch.setenv("SWAZURE_LARGE_PAIRS_BYTES", "1000")
    assert large_pairs_limit() == 1000
    monkeypatch.setenv("SWAZURE_LARGE_PAIRS_BYTES", "a lot")
    with pytest.raises(SwazureError, match="not a whole number of bytes"):
        large_pairs_limit()
    monkeypatch.delenv("SWAZURE_LARGE_PAIRS_BYTES")
    assert large_pairs_limit() == LARGE_PAIRS_BYTES
