"""Where each FLS is, as the coordinator knows it: assigned points, then the newest revision."""

from __future__ import annotations

import numpy as np

from swazure_ros.core.geometry import Swarm
from swazure_ros.protocol.positions import Positions

#: Three FLSs whose rows are not in the cloud's order: FLS k is the point of cloud row k.
SWARM = Swarm(
    points=np.array([[2.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]),
    radius=0.1,
    dmin=1.0,
    beta=None,
    cloud_index=np.array([2, 0, 1]),
    removed=0,
)


def test_every_fls_starts_at_its_assigned_point():
    positions = Positions(SWARM, [0, 1, 2])
    assert np.array_equal(positions.where(np.array([0, 1, 2]))[:, 0], [0.0, 1.0, 2.0])
    assert positions.revision == 0


def test_the_newest_revision_moves_the_flss_it_names_and_an_older_one_is_ignored():
    positions = Positions(SWARM, [0, 1, 2])
    assert positions.takes(3)
    positions.hear(3, np.array([1]), np.array([[5.0, 5.0, 5.0]]))
    assert np.array_equal(positions.where(np.array([1])), [[5.0, 5.0, 5.0]])
    assert positions.revision == 3
    # Older, late on the wire: its positions are not taken, and the revision stays.
    assert not positions.takes(2)
    positions.hear(2, np.array([1, 2]), np.array([[9.0, 9.0, 9.0], [9.0, 9.0, 9.0]]))
    assert np.array_equal(positions.where(np.array([1, 2]))[:, 0], [5.0, 2.0])
    assert positions.revision == 3
    # As new as the newest: taken (the world's revision may name more FLSs).
    positions.hear(3, np.array([2]), np.array([[7.0, 0.0, 0.0]]))
    assert positions.where(np.array([2]))[0, 0] == 7.0
