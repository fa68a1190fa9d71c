"""A swarm's config refuses a layout of processes that cannot run, in the command line's words."""

import pytest

from swazure_ros.app.config import SwarmConfig
from swazure_ros.core.errors import SwazureError
from swazure_ros.sim.world import WorldSpec

WORLD = WorldSpec("torus", beta=0.5)


@pytest.mark.parametrize(
    ("layout", "message"),
    [
        ({"processes": 0}, "--processes must be at least 1"),
        ({"processes": 2, "hosts": 2}, "--share runs one process per host"),
        ({"share": 3, "hosts": 2}, "--share 3/2: no such share"),
        ({"processes": 2, "per_fls": True}, "--per-fls runs one process per FLS"),
    ],
)
def test_a_layout_that_cannot_run_is_refused(layout, message):
    with pytest.raises(SwazureError, match=message):
        SwarmConfig(WORLD, **layout)


def test_a_layout_that_can_run_is_kept():
    config = SwarmConfig(WORLD, processes=2)
    assert (config.processes, config.share, config.hosts) == (2, 0, 1)
