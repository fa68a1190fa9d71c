"""A run's summary as people read it: every row explained from one table, "-" with its reason."""

import re
import subprocess
import sys

import pytest

from swazure_ros.cli.summary import (
    SUMMARY_ROWS,
    SUMMARY_TERMS,
    rows_markdown,
    summary_rows,
    summary_table,
)
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.fit import LEAST_SQUARES, SWARM_FIT, refine
from swazure_ros.core.fusion import fuse
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.heuristics.result import MOVE_OBSTRUCTING
from swazure_ros.files.cloud_files import load_cloud

from ..conftest import REPO
from ..core.fits import stochastic_sensor
from ..waits import PATIENCE

#: A "-" that stands for a value: at the start of a value or of one of its parts.
DASH = re.compile(r"(?:^|[;,/] )-(?! \()(?=$|[ ;,/])")


@pytest.fixture(scope="module")
def summaries(sensor_module):
    """A run of every kind the summary has rows for, and one where no pair has a path."""
    # At scale 4 some blind pairs are blocked, and a heuristic resolves them.
    swarm = make_swarm(load_cloud("torus:120", 4.0).points, beta=0.5)
    plain = evaluate(swarm, sensor_module, "fewest-hops")
    moved, _ = run_technique(plain, MOVE_OBSTRUCTING)
    stochastic = evaluate(swarm, stochastic_sensor(), "fewest-hops")
    small = make_swarm(load_cloud("torus:120").points, beta=0.5)
    return {
        "plain": plain.summary,
        "fused": fuse(plain, 2).summary,
        "moved": moved.summary,
        "least-squares": refine(plain, LEAST_SQUARES).summary,
        "stochastic swarm-fit": refine(stochastic, SWARM_FIT).summary,
        "no path": evaluate(small, sensor_module, "fewest-hops").summary,
        "accurate": evaluate(swarm, sensor_module.error_free(), "fewest-hops").summary,
    }


@pytest.fixture(scope="module")
def sensor_module():
    from swazure_ros.files.sensors import load_sensor

    return load_sensor()


def test_every_row_the_summary_prints_is_explained_and_every_explanation_is_a_row(summaries):
    printed = {label for summary in summaries.values() for label, _ in summary_rows(summary)}
    explained = [label for label, _ in SUMMARY_ROWS]
    assert len(explained) == len(set(explained))
    assert printed == set(explained)


def test_docs_core_holds_the_table_of_rows_word_for_word():
    assert rows_markdown() in (REPO / "docs" / "core.md").read_text()


@pytest.mark.parametrize("verb", ["evaluate", "spawn"])
def test_the_verbs_that_print_a_summary_explain_its_rows_in_their_help(verb):
    done = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", verb, "--help"],
        capture_output=True, text=True, timeout=PATIENCE, check=True,
    )  # fmt: skip
    assert SUMMARY_TERMS in done.stdout
    for label, _ in SUMMARY_ROWS:
        assert f"\n  {label}\n" in done.stdout, label


def test_a_row_shows_a_dash_only_with_its_reason(summaries):
    for kind, summary in summaries.items():
        for label, value in summary_rows(summary):
            assert not DASH.search(value), (kind, label, value)
            assert all(part.startswith("- (") for part in re.findall(r"(?:^|; )(- .*)", value))
    # Beside another run's column, a row only that run has says so.
    table = summary_table(summaries["plain"], ("fit", summaries["least-squares"]))
    nees = next(line for line in table.splitlines() if line.startswith("NEES"))
    assert "- (not in this run)" in nees


def test_a_fit_under_the_bias_model_predicts_no_error_and_says_why(summaries):
    rows = dict(summary_rows(summaries["least-squares"]))
    assert rows["predicted error cm; within it"] == "- (no noise model)"
    assert rows["NEES mean; within chi2 95 %"] == "- (no noise model)"
    # Under a stochastic sensor the fit's covariance is a spread: the row shows it.
    rows = dict(summary_rows(summaries["stochastic swarm-fit"]))
    assert re.fullmatch(r"[\d.e-]+; [\d.]+ %", rows["predicted error cm; within it"])


def test_an_error_free_sensor_predicts_no_error_and_says_so(summaries):
    value = dict(summary_rows(summaries["accurate"]))["predicted error cm; within it"]
    assert value == "0 (an error-free sensor)"


def test_a_heuristic_s_moved_pairs_leave_the_others_predicted_error_and_are_counted(summaries):
    summary = summaries["moved"]
    pairs, resolved = summary.pairs, summary.heuristic.resolved_pairs
    assert resolved > 0
    # The mean and the share are of the pairs that have a prediction: not "-".
    assert pairs.predicted_error_cm.count == pairs.sweet_pairs + pairs.decaying_pairs - resolved
    value = dict(summary_rows(summary))["predicted error cm; within it"]
    assert re.fullmatch(rf"[\d.]+; 100\.0 % \({resolved} moved: none\)", value), value


def test_a_run_where_no_pair_has_a_path_shows_why_in_each_row(summaries):
    rows = dict(summary_rows(summaries["no path"]))
    assert rows["no path"] == "100.000 %"
    assert rows["predicted error cm; within it"] == "- (no pair has a path)"
    assert rows["distance error, %: mean / max"] == "- (no pair has a path)"
    assert rows["obstructed sweet paths"] == "- (no pair in the sweet graph)"
