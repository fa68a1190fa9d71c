"""Run folders read back (files.runs): summaries, per-pair errors, refusals, comparisons."""

import csv
import io
import json
import re
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import REASON_NAMES
from swazure_ros.core.summary import Source
from swazure_ros.files.atomic import write_json
from swazure_ros.files.results import COMPACT_PAIRS, SUMMARY_FILE, write_evaluation
from swazure_ros.files.runs import (
    COMPARISON_CSV,
    COMPARISON_JSON,
    compare_runs,
    read_pair_errors,
    read_run,
    read_summary,
    run_labels,
    write_comparison,
)

from ..conftest import scene


def evaluation_of(sensor, policy="fewest-hops", cloud="scene"):
    evaluation = evaluate(scene(0, 1, 2, 3, 4), sensor, policy)
    summary = evaluation.summary
    source = Source(cloud, "hand-built", 1.0, 0, "config/sensor.yaml")
    summary = replace(summary, parameters=replace(summary.parameters, source=source))
    return replace(evaluation, summary=summary)


@pytest.mark.parametrize("pairs_format", ["csv", "parquet"])
def test_a_run_folder_reads_back_its_summary_and_each_pairs_error(tmp_path, sensor, pairs_format):
    evaluation = evaluation_of(sensor)
    write_evaluation(tmp_path, evaluation, pairs_format=pairs_format)
    run = read_run(tmp_path)
    assert run.summary == evaluation.summary
    assert run.pairs is not None and run.pairs.name == f"pairs.{pairs_format}"
    errors = read_pair_errors(run.pairs, "cm")
    pairs = evaluation.pairs
    expected = np.linalg.norm(pairs.estimate - pairs.truth, axis=1)
    np.testing.assert_allclose(errors.error, expected, rtol=1e-12)
    assert errors.pair_class.tolist() == pairs.reason.tolist()
    percent = read_pair_errors(run.pairs, "%")
    np.testing.assert_allclose(percent.error, pairs.distance_error, rtol=1e-12)


def test_a_compact_per_pair_file_compares_by_distance_error(tmp_path, sensor):
    # The study's compact files keep no truth: the comparison falls back to the distance
    # error in %, which every per-pair file keeps, for every run alike.
    full, compact = tmp_path / "full", tmp_path / "compact"
    for folder in (full, compact):
        folder.mkdir()
    write_evaluation(full, evaluation_of(sensor))
    write_evaluation(compact, evaluation_of(sensor), pairs_format="parquet", columns=COMPACT_PAIRS)
    comparison = compare_runs([full, compact])
    assert comparison.error_unit == "%"
    assert comparison.class_rows[1].label == "all pairs: median error, %"


def test_not_a_run_folder_is_one_line(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(SwazureError, match=re.escape("nosuch: not a run folder (no such folder)")):
        read_run(tmp_path / "nosuch")
    with pytest.raises(SwazureError, match=re.escape("afile: not a run folder (not a folder)")):
        read_run(tmp_path / "afile")
    with pytest.raises(SwazureError, match=re.escape("not a run folder: no summary.json")):
        read_run(tmp_path)
    (tmp_path / SUMMARY_FILE).write_text('{"flss": 3}')
    with pytest.raises(
        SwazureError, match=re.escape("summary.json: not a run's summary (KeyError")
    ):
        read_run(tmp_path)
    (tmp_path / SUMMARY_FILE).write_text("{not json")
    with pytest.raises(SwazureError, match="not a run's summary"):
        read_summary(tmp_path / SUMMARY_FILE)


def test_a_pairs_file_with_an_unknown_reason_or_no_columns_is_refused(tmp_path, sensor):
    write_evaluation(tmp_path, evaluation_of(sensor))
    path = tmp_path / "pairs.csv"
    rows = list(csv.reader(path.read_text().splitlines()))
    rows[1][rows[0].index("reason")] = "GREMLINS"
    text = io.StringIO()
    csv.writer(text).writerows(rows)
    path.write_text(text.getvalue())
    with pytest.raises(SwazureError, match=re.escape(f"reason is none of {REASON_NAMES}")):
        read_pair_errors(path, "cm")
    path.write_text("source,target\n0,1\n")
    with pytest.raises(SwazureError, match=re.escape("pairs.csv: not a per-pair table")):
        read_pair_errors(path, "cm")


def test_runs_of_two_clouds_are_refused_before_their_pairs_are_read(tmp_path, sensor):
    one, other = tmp_path / "one", tmp_path / "other"
    for folder, cloud in ((one, "chess_408"), (other, "dragon_1147")):
        folder.mkdir()
        write_json(folder / SUMMARY_FILE, evaluation_of(sensor, cloud=cloud).summary.as_document())
        (folder / "pairs.csv").write_text("not a pairs table\n")  # never read
    with pytest.raises(SwazureError, match="different clouds: one \\(chess_408\\), other"):
        compare_runs([one, other])
    with pytest.raises(SwazureError, match="a run given twice"):
        compare_runs([one, tmp_path / "." / "one"])
    with pytest.raises(SwazureError, match="two or more runs, got 1"):
        compare_runs([one])


def test_labels_are_folder_names_unless_two_are_one(tmp_path):
    assert run_labels([tmp_path / "a" / "run", tmp_path / "b" / "other"]) == ["run", "other"]
    twins = [tmp_path / "a" / "run", tmp_path / "b" / "run"]
    assert run_labels(twins) == [str(path) for path in twins]


def test_the_comparison_is_written_as_json_and_csv(tmp_path, sensor):
    folders = []
    for name, policy in (("fewest", "fewest-hops"), ("shortest", "shortest-length")):
        folder = tmp_path / name
        folder.mkdir()
        write_evaluation(folder, evaluation_of(sensor, policy))
        folders.append(folder)
    comparison = compare_runs(folders)
    json_path, csv_path = write_comparison(tmp_path / "out", comparison)
    assert (json_path.name, csv_path.name) == (COMPARISON_JSON, COMPARISON_CSV)
    document = json.loads(json_path.read_text())
    assert [run["label"] for run in document["runs"]] == ["fewest", "shortest"]
    assert [verdict["statement"] for verdict in document["verdicts"]] == [
        verdict.statement for verdict in comparison.verdicts
    ]
    table = list(csv.DictReader(csv_path.read_text().splitlines()))
    assert [row["row"] for row in table] == [
        row.label for row in (*comparison.rows, *comparison.class_rows)
    ]
    blind = next(row for row in table if row["row"] == "ordered blind pairs")
    assert float(blind["fewest"]) == comparison.runs[0].summary.pairs.blind_pairs
    assert float(blind["delta shortest"]) == 0.0
    assert not list((tmp_path / "out").glob(".*"))  # no temporary file left behind


def test_a_run_without_a_per_pair_file_is_compared_by_its_summary_alone(tmp_path, sensor):
    folders = [tmp_path / "a", tmp_path / "b", tmp_path / "c"]
    for folder in folders:
        folder.mkdir()
        write_evaluation(folder, evaluation_of(sensor))
    (folders[1] / "pairs.csv").unlink()
    comparison = compare_runs(folders)
    assert [run.classes is None for run in comparison.runs] == [False, True, False]
    blind = next(row for row in comparison.rows if row.label == "ordered blind pairs")
    assert blind.values == (comparison.runs[0].summary.pairs.blind_pairs,) * 3
    coverage = next(row for row in comparison.class_rows if row.label == "all pairs: coverage, %")
    assert coverage.values[1] is None and coverage.values[0] == coverage.values[2]
    (folders[2] / "pairs.csv").unlink()
    assert compare_runs(folders).verdicts == ()  # one run with pairs: nothing to judge
