"""The swarm's own fit over real DDS: a packed swarm's estimates are the engine's."""

from __future__ import annotations

import numpy as np
import pytest

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH
from swazure_ros.core.fit import SWARM_FIT, refine
from swazure_ros.files.reading import config_dir
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.sim.world import WorldSpec

CALIBRATED = str(config_dir() / "cameras" / "sensor-wide-calibrated.yaml")


@pytest.fixture
def params(tmp_path):
    """Slow measurement messages (a run does not need them)."""
    path = tmp_path / "swarm.yaml"
    path.write_text("/**:\n  ros__parameters:\n    publish_period: 5.0\n")
    return path


@pytest.mark.parametrize("processes", [1, 2])
def test_a_swarm_solves_its_fit_by_messages_as_the_engine_does(domain, params, processes):
    # The calibrated stochastic sensor: one fit with the joining decaying hops, reweighted
    # by the robust loss, then the covariance's 64 sampled right sides. Over two processes
    # each hears the other's offers over DDS beside its own FLSs' block of each round.
    world = WorldSpec("torus:120", scale=2.0, beta=0.5, sensor_file=CALIBRATED)
    config = SwarmConfig(world, processes=processes, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        built = swarm.world
        result = swarm.discover("shortest-length", timeout=300, estimator=SWARM_FIT)
        heard_over_dds = swarm.host.radio.offers_heard
    if processes == 2:
        assert heard_over_dds > 0
    engine = refine(evaluate(built.swarm, built.sensor, "shortest-length"), SWARM_FIT)
    assert result.outcome.departed == frozenset() and result.outcome.restarts == 0
    found = {(s, one.target): one for s, ones in result.outcome.estimates.items() for one in ones}
    pairs, ids = engine.pairs, built.ids
    assert len(found) == len(pairs)
    fitted = 0
    for pair in np.flatnonzero(pairs.status != NO_PATH):
        one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
        assert one.estimator == SWARM_FIT
        np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-9)
        np.testing.assert_allclose(
            one.covariance, pairs.covariance[pair], rtol=0, atol=1e-9 * one.covariance.max()
        )
        fitted += 1
    assert fitted > 1000
    # The run's evaluation says what made its estimates, and its NEES is the engine's.
    distributed = evaluation_of(built.hood, "shortest-length", result.outcome.estimates)
    assert distributed.summary.fit.estimator == SWARM_FIT
    nees = distributed.summary.fit.consistency.nees.mean
    assert nees == pytest.approx(engine.summary.fit.consistency.nees.mean, rel=1e-9)
