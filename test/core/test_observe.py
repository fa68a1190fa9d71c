"""What each FLS observes, laid out per FLS (core.observe)."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.core import observe
from swazure_ros.core.neighbourhood import neighbourhood
from swazure_ros.core.observe import observations
from swazure_ros.sim.world import WorldSpec

from .fits import stochastic_sensor

COLUMNS = ("indptr", "other", "range_class", "visible", "vector", "tracking", "distance")


@pytest.mark.parametrize("owners", [None, "every third"])
def test_camera_readings_made_block_by_block_are_those_made_at_once(monkeypatch, owners):
    # A stochastic sensor: each pair's reading has its own seeded draw, wherever it is made.
    world = WorldSpec("torus:120", scale=1.6, beta=0.3).build()
    hood = neighbourhood(world.swarm, stochastic_sensor(mean_error=0.03))
    hosted = None if owners is None else np.arange(0, world.swarm.size, 3)
    whole = observations(hood, hosted)
    measured = int(whole.measured.sum())
    assert measured > 300  # so about 4 blocks or more
    monkeypatch.setattr(observe, "CAMERA_BLOCK", 97)  # many blocks, the last one short
    blocks = observations(hood, hosted)
    for name in COLUMNS:
        np.testing.assert_array_equal(getattr(blocks, name), getattr(whole, name), err_msg=name)
    if hosted is not None:  # only the hosted FLSs' rows
        rows = np.diff(whole.indptr)
        assert rows[hosted].sum() == len(whole.other) and rows.sum() == len(whole.other)
