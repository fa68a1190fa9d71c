"""Study tables and figure statistics from hand-written summaries whose values are obvious."""

import csv
import io

import numpy as np
import pytest

from swazure_ros.core.clouds import Cloud
from swazure_ros.core.metrics import NO_VALUES, Stats
from swazure_ros.core.summary import HeuristicFacts, PairStatistics, Parameters, Summary
from swazure_ros.study.figures import box_stats
from swazure_ros.study.plan import PLAIN_TECHNIQUE, StudyPlan, Technique
from swazure_ros.study.sweep import SweepResult
from swazure_ros.study.tables import errors_table, moved_table, paths_table, study_tables

MO = Technique("move-obstructing")
MS2 = Technique("move-source", 2)
TECHNIQUE_CODE = {PLAIN_TECHNIQUE: 0, MO: 1, MS2: 2}


def stats(mean=None, max=None, count=0):
    return Stats(mean, max, None, None, None, count)


def fake_summary(shape_code, beta, technique):
    """Values that spell out where they came from: shape, beta and technique."""
    code = TECHNIQUE_CODE[technique]
    pairs = PairStatistics(
        blind_pairs=7, sweet_pairs=0, decaying_pairs=0, no_path_pairs=0, sweet_pct=50.0,
        decaying_pct=1000 * shape_code + 10 * beta + code,
        no_path_pct=100 * shape_code + 10 * beta + code,
        blocked_pairs=0, no_sweet_path_pairs=0,
        distance_error_pct=stats(beta, 2 * beta),
        distance_error_pct_sweet_paths=NO_VALUES, distance_error_pct_decaying_paths=NO_VALUES,
        alpha_deg=stats(3 * beta, 4 * beta), theta_deg=NO_VALUES, phi_deg=NO_VALUES,
        hops=NO_VALUES, hops_sweet_paths=NO_VALUES, hops_decaying_paths=NO_VALUES,
        sweet_connected_pairs=0, obstructed_path_pct=90.0,
        obstructing_flss_per_path=stats(2.5), predicted_error_cm=NO_VALUES,
        within_predicted_pct=0.0, obstructing_flss_histogram=(), quantiles="exact",
    )  # fmt: skip
    heuristic = None
    if technique != PLAIN_TECHNIQUE:
        source = technique.name == "move-source"
        heuristic = HeuristicFacts(
            technique.name, technique.threshold, tried_pairs=20, resolved_pairs=10 + code,
            moved_distance=stats(0.1 * code, 0.2 * code, 5), failed_moved_distance=NO_VALUES,
            moved_per_resolved_pair=NO_VALUES, compat=(),
            flown_distance=stats(1.5, 3.0) if source else None,
        )  # fmt: skip
    parameters = Parameters("shortest-length", beta, 1.0, {}, False)
    return Summary(
        flss=2, cloud_points=2, removed=0, radius=1.0, dmin=2.0, beta=beta, kissing_pairs=0,
        sweet_neighbour_pairs=0, decaying_neighbour_pairs=0, pairs=pairs,
        parameters=parameters, version="test", heuristic=heuristic,
    )  # fmt: skip


@pytest.fixture
def study(sensor):
    clouds = [
        Cloud("small", np.zeros((2, 3)), 1.0, "builtin"),
        Cloud("large", np.zeros((3, 3)), 1.0, "builtin"),
    ]
    plan = StudyPlan(
        clouds,
        sensor,
        betas=(0.3, 0.4, 0.5),
        policies=("shortest-length",),
        techniques=(MO, MS2),
        heuristic_betas=(0.3, 0.4, 0.5),
    )
    codes = {"small": 1, "large": 2}
    summaries = {
        spec: fake_summary(codes[spec.cloud], spec.beta, spec.technique) for spec in plan.runs()
    }
    return plan, SweepResult(summaries, len(summaries), 0, 0.0, 0.0)


def rows(table):
    return list(csv.DictReader(io.StringIO(table.to_csv())))


def test_paths_table_follows_the_published_layout(study):
    plan, result = study
    table = paths_table(plan, result, MO)
    assert table.columns == [
        "shape",
        "flss",
        "no_path_pct_beta_0.4",
        "no_path_pct_beta_0.5",
        "decaying_pct_beta_0.3",
        "decaying_pct_beta_0.4",
        "decaying_pct_beta_0.5",
    ]
    small, large = rows(table)
    assert (small["shape"], small["flss"], large["shape"]) == ("small", "2", "large")
    assert float(small["no_path_pct_beta_0.4"]) == pytest.approx(100 + 4 + 1)
    assert float(large["decaying_pct_beta_0.3"]) == pytest.approx(2000 + 3 + 1)
    assert "| small | 2 | 105.00 | 106.00 | 1004.00 | 1005.00 | 1006.00 |" in table.to_markdown()


def test_moved_table_reports_each_heuristic_at_the_largest_beta(study):
    plan, result = study
    table = moved_table(plan, result)
    assert table.name == "moved_beta_0.5"
    small = rows(table)[0]
    assert float(small["move-obstructing_moved_mean_cm"]) == pytest.approx(0.1)
    assert float(small["move-source-T2_moved_max_cm"]) == pytest.approx(0.4)
    assert float(small["move-source-T2_flown_max_cm"]) == pytest.approx(3.0)
    assert small["move-obstructing_resolved"] == "11"
    assert "0.100 (0.200)" in table.to_markdown()


def test_errors_table_has_a_row_per_plain_run(study):
    plan, result = study
    table = rows(errors_table(plan, result))
    assert len(table) == 2 * 3
    assert {row["policy"] for row in table} == {"shortest-length"}
    row = next(r for r in table if r["shape"] == "large" and r["beta"] == "0.4")
    assert float(row["alpha_max_deg"]) == pytest.approx(1.6)


def test_missing_runs_are_empty_cells_not_errors(study):
    plan, result = study
    absent = Technique("move-source", 10)
    table = paths_table(plan, result, absent)
    assert rows(table)[0]["no_path_pct_beta_0.5"] == ""
    assert "| - |" in table.to_markdown()


def test_study_tables_are_plain_each_heuristic_moved_and_errors(study):
    plan, result = study
    names = [table.name for table in study_tables(plan, result)]
    assert names == [
        "paths_plain",
        "paths_move-obstructing",
        "paths_move-source-T2",
        "moved_beta_0.5",
        "errors",
    ]


def test_box_stats_from_counts_per_value():
    # Samples 1, 1, 2, 3 given as counts of 0, 1, 2, 3.
    box = box_stats([0, 2, 1, 1], "b")
    assert (box["whislo"], box["q1"], box["med"], box["q3"], box["whishi"]) == (1, 1, 1, 2, 3)
    assert box["mean"] == pytest.approx(7 / 4)
    assert box_stats([0, 0], "empty") is None
