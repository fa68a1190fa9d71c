"""core/judged_sight.py: the decaying pairs' sight, each pair judged once, read back after."""

import threading

import numpy as np

from swazure_ros.core import judged_sight
from swazure_ros.core.grid import build_grid
from swazure_ros.core.judged_sight import JudgedSight
from swazure_ros.core.neighbours import neighbour_pairs
from swazure_ros.core.sensor import DECAYING
from swazure_ros.core.sight import obstructed

from .test_local_paths import plane


def decaying_pairs(swarm, sensor):
    """The swarm's decaying pairs, and whether each is in sight by the plain scan."""
    every = neighbour_pairs(swarm, sensor)
    decaying = every.range_class == DECAYING
    first, second = every.first[decaying], every.second[decaying]
    return first, second, ~obstructed(swarm.points, swarm.radius, first, second)


def counting_judge(monkeypatch):
    """The pairs the sight judges, as it asks them, the real judgements kept."""
    asked = []
    real = judged_sight.obstructed_fans

    def judged(points, radius, ends, others, **kwargs):
        asked.extend(zip(ends.tolist(), others.tolist(), strict=True))
        return real(points, radius, ends, others, **kwargs)

    monkeypatch.setattr(judged_sight, "obstructed_fans", judged)
    return asked


def test_a_pair_s_sight_is_judged_once_and_read_back_in_later_regions(sensor, monkeypatch):
    # 1,600 FLSs' decaying pairs asked in three overlapping sets, over 3,000 pairs in all:
    # the hash is widened at least twice on the way and every answer is the scan's.
    swarm = plane()
    first, second, expected = decaying_pairs(swarm, sensor)
    asked = counting_judge(monkeypatch)
    sight, grid = JudgedSight(swarm.size), build_grid(swarm.points, swarm.radius)
    for part in (slice(0, 2000), slice(1000, 3500), slice(0, len(first))):
        seen = sight.of(swarm, grid, first[part], second[part])
        assert np.array_equal(seen, expected[part])
    assert len(first) > 3000 and 0.05 < expected.mean() < 0.95
    assert sight.judged == len(asked) == len(set(asked)) == len(first)
    assert len(sight.table) >= 4096


def test_regions_asking_at_once_get_the_scan_s_answers_and_each_pair_is_counted_once(
    sensor, monkeypatch
):
    # Four threads ask overlapping halves of the pairs, released together: a pair two of
    # them judge before either enters it is entered, and counted, once.
    swarm = plane()
    first, second, expected = decaying_pairs(swarm, sensor)
    asked = counting_judge(monkeypatch)
    sight, grid = JudgedSight(swarm.size), build_grid(swarm.points, swarm.radius)
    half = len(first) // 2
    parts = [slice(0, half), slice(half // 2, half + half // 2), slice(half, None), slice(0, None)]
    start, answers = threading.Barrier(len(parts)), {}

    def ask(part):
        start.wait()
        answers[part.start, part.stop] = sight.of(swarm, grid, first[part], second[part])

    threads = [threading.Thread(target=ask, args=(part,)) for part in parts]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for part in parts:
        assert np.array_equal(answers[part.start, part.stop], expected[part])
    assert sight.judged == len(set(asked)) == len(first)  # each pair entered once
    again = sight.of(swarm, grid, first, second)  # all read back, none judged anew
    assert np.array_equal(again, expected) and sight.judged == len(first)
