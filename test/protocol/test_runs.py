import pytest

from swazure_ros.protocol.rounds import Outcome
from swazure_ros.protocol.runs import (
    LABEL_BYTES,
    DiscoveryResult,
    Traffic,
    merged,
    source_blocks,
    sources_per_run,
)


def test_source_blocks_are_consecutive_ids_as_even_as_they_go():
    blocks = source_blocks([9, 3, 4, 5, 7, 8, 3], per_run=2)
    assert blocks == [(3, 4), (5, 7), (8, 9)]
    assert source_blocks(range(10), per_run=4) == [(0, 1, 2), (3, 4, 5), (6, 7, 8, 9)]
    assert source_blocks(range(5), per_run=100) == [(0, 1, 2, 3, 4)]


def test_a_block_holds_at_least_one_source():
    with pytest.raises(ValueError, match="at least 1"):
        source_blocks(range(5), per_run=0)


def test_sources_per_run_keeps_the_labels_within_the_memory_given():
    assert sources_per_run(1000, label_memory=1000 * 250 * LABEL_BYTES) == 250
    # A published shape's every source fits in one run; 10,000 FLSs need several.
    assert sources_per_run(3720) >= 3720
    assert sources_per_run(10_000) < 10_000
    assert sources_per_run(10**9) == 1


def _result(run_id, estimates, rounds, traffic, departed=(), incomplete=False):
    outcome = Outcome(estimates, frozenset(departed), rounds, 1, repairs=3, incomplete=incomplete)
    return DiscoveryResult(run_id, "shortest-length", outcome, 2.0, traffic)


def test_merged_blocks_sum_what_each_took_and_keep_every_source_s_estimates():
    first = _result(4, {1: ["a"]}, 10, Traffic({"discovery": 5}, {"discovery": 50}))
    traffic = Traffic({"discovery": 2, "radio": 1}, {"discovery": 9, "radio": 7})
    second = _result(5, {2: ["b"]}, 12, traffic, departed=[3], incomplete=True)
    one = merged([first, second])
    outcome = one.outcome
    assert one.run_id == 4 and outcome.estimates == {1: ["a"], 2: ["b"]}
    assert (outcome.rounds, outcome.restarts, one.seconds, outcome.repairs) == (22, 2, 4.0, 6)
    assert one.traffic.messages == {"discovery": 7, "radio": 1}
    assert one.traffic.bytes == {"discovery": 59, "radio": 7}
    assert outcome.departed == frozenset({3}) and outcome.incomplete
