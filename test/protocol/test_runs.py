import numpy as np
import pytest

from swazure_ros.protocol.discovery.labels import LabelTable
from swazure_ros.protocol.discovery.links import Links
from swazure_ros.protocol.rounds import Outcome
from swazure_ros.protocol.runs import (
    LABEL_MEMORY,
    SHARE_LABEL_MEMORY,
    DiscoveryResult,
    Traffic,
    merged,
    next_block,
    next_block_size,
    source_blocks,
    sources_per_run,
    swarm_label_memory,
)


def test_source_blocks_spread_over_the_ids_as_even_as_they_go():
    blocks = source_blocks([9, 3, 4, 5, 7, 8, 3], per_run=2)
    assert blocks == [(3, 7), (4, 8), (5, 9)]
    assert source_blocks(range(10), per_run=4) == [(0, 3, 6, 9), (1, 4, 7), (2, 5, 8)]
    assert source_blocks(range(5), per_run=100) == [(0, 1, 2, 3, 4)]


def test_the_next_block_is_the_first_of_the_blocks_and_leaves_the_rest():
    assert next_block([9, 3, 4, 5, 7, 8], per_run=2) == ((3, 7), (4, 5, 8, 9))
    # Runs sized one after the other cover every id once.
    left, taken = tuple(range(10)), []
    for size in (4, 2, 100):
        block, left = next_block(left, size)
        taken.extend(block)
    assert sorted(taken) == list(range(10)) and left == ()


def test_a_block_holds_at_least_one_source():
    with pytest.raises(ValueError, match="at least 1"):
        source_blocks(range(5), per_run=0)


def test_sources_per_run_keeps_the_labels_within_the_memory_given():
    # 1,000 FLSs each holding a label of each of 250 sources: a slot per source a row,
    # as the tables of a run lay them out, with and without a fitting run's columns.
    for fits in (False, True):
        no_hops = Links(
            *(np.zeros(0, dtype=dtype) for dtype in (np.int64, float, float)), np.zeros((0, 3))
        )
        starts = np.zeros(1001, dtype=np.int64)
        table = LabelTable(np.arange(1000), starts, no_hops, (0, 250), 250, fits, need=250)
        assert table.direct and table.width == 250
        memory = table.size * table.row_bytes
        assert sources_per_run(1000, label_memory=memory, fits=fits) == 250
        assert sources_per_run(1000, label_memory=memory - 1, fits=fits) == 249
    # A published shape's every source fits in one run; 10,000 FLSs need several.
    assert sources_per_run(3720) >= 3720
    assert sources_per_run(10_000) < 10_000
    assert sources_per_run(10**9) == 1


def test_the_next_block_grows_as_far_as_the_last_blocks_labels_leave_memory_for():
    # 100 sources took 1 MB: 2 MB for twice the labels at most, so 16 MB take 800.
    assert next_block_size(100, 10**6, label_memory=16 * 10**6) == 800
    # Never smaller than the last, and the last again when nothing was measured.
    assert next_block_size(100, 10**8, label_memory=16 * 10**6) == 100
    assert next_block_size(100, 0, label_memory=16 * 10**6) == 100


def test_a_swarm_over_more_shares_keeps_more_labels_and_each_share_what_one_of_two_does():
    # One process or two: the swarm's 1 GiB, half a share of two.
    assert swarm_label_memory(1) == swarm_label_memory(2) == LABEL_MEMORY
    assert LABEL_MEMORY == 2 * SHARE_LABEL_MEMORY
    # Four shares of torus:30000 hold twice the labels at once, in blocks twice as large,
    # each share as many labels as one of two holds.
    assert swarm_label_memory(4) == 2 * LABEL_MEMORY
    assert sources_per_run(30_000, swarm_label_memory(4)) // 2 == sources_per_run(30_000)
    assert swarm_label_memory(0) == LABEL_MEMORY


def _result(run_id, estimates, rounds, traffic, departed=(), incomplete=False, label_bytes=0):
    outcome = Outcome(
        estimates,
        frozenset(departed),
        rounds,
        1,
        repairs=3,
        incomplete=incomplete,
        label_bytes=label_bytes,
    )
    return DiscoveryResult(run_id, "shortest-length", outcome, 2.0, traffic)


def test_merged_blocks_sum_what_each_took_and_keep_every_source_s_estimates():
    first = _result(4, {1: ["a"]}, 10, Traffic({"discovery": 5}, {"discovery": 50}), label_bytes=9)
    traffic = Traffic({"discovery": 2, "radio": 1}, {"discovery": 9, "radio": 7})
    second = _result(5, {2: ["b"]}, 12, traffic, departed=[3], incomplete=True, label_bytes=7)
    one = merged([first, second])
    outcome = one.outcome
    assert one.run_id == 4 and outcome.estimates == {1: ["a"], 2: ["b"]}
    assert (outcome.rounds, outcome.restarts, one.seconds, outcome.repairs) == (22, 2, 4.0, 6)
    assert one.traffic.messages == {"discovery": 7, "radio": 1}
    assert one.traffic.bytes == {"discovery": 59, "radio": 7}
    assert outcome.departed == frozenset({3}) and outcome.incomplete
    assert outcome.label_bytes == 9  # one run after the other: the most either held
