"""A summary read back from its summary.json document is the summary written."""

import json
from dataclasses import replace

import pytest

from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.pipeline import RunOptions, run_engine
from swazure_ros.core.summary import Source, StudyRun, Summary
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.sensors import load_sensor

CLOUD = load_cloud("torus:120", 1.6)
SOURCE = Source.of(CLOUD, 3, "config/sensor.yaml")

#: Runs whose summaries hold every kind of facts: a heuristic (Move Source's two more
#: statistics, the published code's switches), fusion, and each fit (window and
#: iteration facts).
RUNS = {
    "plain": RunOptions(),
    "move-source": RunOptions(technique="move-source", threshold=3),
    "move-source-published": RunOptions(technique="move-source", threshold=2, compat="published"),
    "move-obstructing": RunOptions(technique="move-obstructing"),
    "fused": RunOptions(fuse=2),
    "least-squares": RunOptions(estimator="least-squares"),
    "local-least-squares": RunOptions(estimator="local-least-squares"),
    "swarm-fit": RunOptions(estimator="swarm-fit"),
}


@pytest.fixture(scope="module")
def summaries():
    swarm, sensor = make_swarm(CLOUD.points, beta=0.5), load_sensor()
    plain = run_engine(swarm, sensor, RunOptions(), hold=True, source=SOURCE)
    return {name: run_engine(swarm, sensor, options, plain=plain).summary
            for name, options in RUNS.items()}  # fmt: skip


def through_json(summary: Summary) -> Summary:
    """``summary`` written as summary.json's text and read back."""
    return Summary.from_document(json.loads(json.dumps(summary.as_document())))


@pytest.mark.parametrize("name", sorted(RUNS))
def test_from_document_reads_back_what_as_document_wrote(summaries, name):
    summary = summaries[name]
    assert Summary.from_document(summary.as_document()) == summary
    assert through_json(summary) == summary
    assert through_json(summary).as_document() == summary.as_document()


def test_the_round_trip_keeps_a_study_run_no_source_and_sketched_quantiles(summaries):
    plain = summaries["plain"]
    study = replace(plain, study=StudyRun("abc", "runs/torus/beta-0.5", "compact"))
    assert through_json(study) == study
    bare = replace(plain, parameters=replace(plain.parameters, source=None), seconds=None)
    assert through_json(bare) == bare
    sketched = replace(plain, pairs=replace(plain.pairs, quantiles="sketched"))
    assert through_json(sketched) == sketched
    assert through_json(sketched).as_document()["quantiles"].startswith("sketched")


def test_every_kind_of_facts_is_in_the_runs(summaries):
    # The round trip above meets each optional part of a summary at least once.
    assert summaries["move-source"].heuristic.flown_distance is not None
    assert summaries["move-source-published"].heuristic.compat
    assert summaries["fused"].fusion is not None
    assert summaries["local-least-squares"].fit.window_flss is not None
    assert summaries["swarm-fit"].fit.iterations is not None
    assert summaries["plain"].parameters.source == SOURCE
