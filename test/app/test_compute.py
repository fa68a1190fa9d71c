"""app.compute: when a swarm's run is not the engine's work, it says so in one line."""

from __future__ import annotations

from swazure_ros.app.compute import run_failure
from swazure_ros.files.record import Distributed, RunRecord


def record(identical: str, departed: list[int] | None = None, incomplete: bool = False):
    distributed = Distributed(1.0, 3, 0, departed or [], {}, {}, incomplete=incomplete)
    return RunRecord("spawn", 1.0, None, identical=identical, distributed=distributed)


def test_a_run_equal_to_the_engine_is_no_failure():
    assert run_failure(record("yes")) is None


def test_pairs_that_differ_are_a_failure_that_says_what_differs():
    failure = run_failure(record("no: 0 pairs reported, the engine has 120"))
    assert failure == "the pairs are not the engine's (no: 0 pairs reported, the engine has 120)"


def test_departed_flss_are_named_even_when_the_pairs_agree():
    failure = run_failure(record("yes", departed=list(range(12))))
    assert failure == "12 FLSs did not take part to the end (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, ...)"


def test_lost_deliveries_are_a_failure():
    assert run_failure(record("yes", incomplete=True)) == "radio deliveries were lost for good"
