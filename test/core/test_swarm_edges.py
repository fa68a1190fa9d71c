"""The swarm's fit's edges: each measured pair as two directed edges, one into each end."""

import pytest

from swazure_ros.core.swarm_edges import edges_of

from .fits import exact


def test_a_pair_measured_from_one_end_only_is_refused():
    with pytest.raises(ValueError, match="both ends"):
        edges_of(2, exact([0], [1], [[7.0, 0, 0]]))
