"""app.share: a process's share of the swarm, and what its bring-up says when it fails."""

from __future__ import annotations

import numpy as np

from swazure_ros.app.share import shares, unreached_text
from swazure_ros.core.geometry import make_swarm


def test_shares_are_compact_regions_of_ids_not_runs_of_ids():
    # Ids alternate between the two ends of a line: runs of ids would mix both ends.
    points = np.array([[0.0, 0, 0], [100, 0, 0], [1, 0, 0], [101, 0, 0], [2, 0, 0], [102, 0, 0]])
    swarm = make_swarm(points, radius=0.1)
    assert shares(swarm, 2) == [[0, 2, 4], [1, 3, 5]]


def test_a_bring_up_names_the_flss_it_could_not_reach():
    assert unreached_text([]) == ""
    assert unreached_text([4, 9]) == "; FLSs not reached: 4, 9 (2 in all)"
    many = unreached_text(list(range(30)))
    assert many == "; FLSs not reached: 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, ... (30 in all)"
