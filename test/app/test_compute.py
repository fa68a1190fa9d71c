"""app.compute: a swarm's pairs beside the engine's, as a record; and when a swarm's run is
not the engine's work, it says so in one line."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.app.compute import run_failure, same_results
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import Evaluation
from swazure_ros.core.geometry import make_swarm
from swazure_ros.files.record import Distributed, EngineComparison, RunRecord

from ..conftest import SCENE

SAME = EngineComparison(120, 120)


def record(comparison: EngineComparison, departed: list[int] | None = None, incomplete=False):
    distributed = Distributed(1.0, 3, 0, departed or [], {}, {}, incomplete=incomplete)
    return RunRecord("spawn", 1.0, None, comparison=comparison, distributed=distributed)


@pytest.fixture
def engine(sensor) -> Evaluation:
    return evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")


def test_pairs_that_are_the_engines_are_identical(engine, sensor):
    again = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")
    comparison = same_results(again, engine)
    assert comparison == EngineComparison(len(engine.pairs), len(engine.pairs), 0, 0, False)
    assert comparison.identical and comparison.describe() == "yes"


def test_pairs_that_differ_are_counted_by_what_differs(engine):
    pairs = engine.pairs
    status, estimate, nodes = pairs.status.copy(), pairs.estimate.copy(), pairs.nodes.copy()
    status[0] = 1 - status[0] if status[0] < 2 else 0
    estimate[1:3] += 1e-6  # two estimates 1e-6 cm off: beyond the 1e-9 cm allowed
    estimate[3] += 1e-12  # one within it
    nodes[0] = nodes[-1]
    ours = replace(engine, pairs=replace(pairs, status=status, estimate=estimate, nodes=nodes))
    comparison = same_results(ours, engine)
    assert comparison == EngineComparison(len(pairs), len(pairs), 1, 2, True)
    assert not comparison.identical
    assert comparison.describe() == "no: 1 statuses, 2 estimates differ; paths differ: True"


def test_pairs_of_another_number_are_not_compared_one_by_one(engine, sensor):
    fewer = evaluate(make_swarm(np.array(SCENE[:3]), radius=0.5), sensor, "shortest-length")
    comparison = same_results(fewer, engine)
    found, known = len(fewer.pairs), len(engine.pairs)
    assert found < known
    assert comparison == EngineComparison(found, known, None, None, None)
    assert not comparison.identical
    assert comparison.describe() == f"no: {found} pairs reported, the engine has {known}"


def test_a_run_equal_to_the_engine_is_no_failure():
    assert run_failure(record(SAME)) is None


def test_pairs_that_differ_are_a_failure_that_says_what_differs():
    failure = run_failure(record(EngineComparison(0, 120, None, None, None)))
    assert failure == "the pairs are not the engine's (no: 0 pairs reported, the engine has 120)"


def test_departed_flss_are_named_even_when_the_pairs_agree():
    failure = run_failure(record(SAME, departed=list(range(12))))
    assert failure == "12 FLSs did not take part to the end (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, ...)"


def test_lost_deliveries_are_a_failure():
    assert run_failure(record(SAME, incomplete=True)) == "radio deliveries were lost for good"
