"""The client of a running swarm (swazure_ros.api.client) over real DDS, against the engine."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("rclpy", reason="rclpy (ROS 2 Jazzy wheels) is not installed")

from swazure_ros import api
from swazure_ros.core.errors import OptionError, RunError, SwazureError
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.core.evaluation import STATUS_NAMES

from ..waits import PATIENCE

# torus:120 at 1.6 x has sweet, blocked and unreachable pairs (test/ros/test_discovery.py).
SHAPE = ("torus:120", 1.6, 0.5)


@pytest.fixture
def params(tmp_path):
    """Slow measurement messages: the questions here do not need them."""
    path = tmp_path / "swarm.yaml"
    path.write_text("/**:\n  ros__parameters:\n    publish_period: 5.0\n")
    return path


@pytest.fixture
def spawned(domain, params):
    """`swazure spawn` of SHAPE on the test's domain, served until the test ends."""
    cloud, scale, beta = SHAPE
    spawn = subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", "--cloud", cloud,
         "--scale", str(scale), "--beta", str(beta), "--quiet", "--params", str(params)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        line = spawn.stdout.readline()
        assert line.startswith("swarm up"), line + spawn.stderr.read()
        yield api.WorldSpec(cloud, scale=scale, beta=beta).build()
    finally:
        spawn.terminate()
        spawn.communicate(timeout=PATIENCE)


def test_a_client_asks_the_swarm_what_the_engine_computes(domain, spawned):
    world = spawned
    engine = evaluate_pairs(world.hood, "shortest-length")
    pair = int(np.flatnonzero(engine.hops >= 2)[0])
    source, target = int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]])
    heard = []
    with api.connect("swarm", domain_id=domain, timeout=PATIENCE) as swarm:
        assert (swarm.namespace, swarm.domain_id) == ("swarm", domain)
        # The FLS's own answer is the world's: blind, sweet and decaying neighbours.
        for fls in (source, target):
            known, truth = swarm.neighbours(fls), world.neighbours(fls)
            assert known.fls_id == fls and known.gone == ()
            assert known.blind == tuple(truth.blind.tolist())
            assert known.sweet == tuple(truth.sweet.tolist())
            assert known.visible_sweet == tuple(truth.visible_sweet.tolist())
            assert known.decaying == tuple(truth.visible_decaying.tolist())
        assert target in swarm.neighbours(source).blind
        # One discovery run of the swarm finds the engine's path and estimate.
        found = swarm.compute_pose(source, target)
        assert STATUS_NAMES[found.status] == STATUS_NAMES[engine.status[pair]]
        assert found.path == tuple(int(world.ids[k]) for k in engine.path(pair))
        np.testing.assert_allclose(found.vector, engine.estimate[pair], rtol=0, atol=1e-9)
        # A topic's messages as records, to a callback as they come and returned.
        records = swarm.echo("measurements", count=3, on_message=heard.append)
        with pytest.raises(SwazureError, match="no target FLS 5000"):
            swarm.compute_pose(source, 5000)
        with pytest.raises(OptionError, match="policy 'shortest'"):
            swarm.compute_pose(source, target, policy="shortest")
        with pytest.raises(OptionError, match="give on_message"):
            swarm.echo("measurements", count=None)
        # A swarm run elsewhere: its whole runs belong to the process that started it.
        with pytest.raises(SwazureError, match="swazure spawn --compute-all there"):
            swarm.compute_all()
    assert len(records) == 3 and heard == records
    # Each record is one FLS's Measurements: poses of its own neighbours, fields by name.
    for record in records:
        fls = record["source_id"]
        sets = world.neighbours(fls)
        near = set(np.concatenate([sets.blind, sets.sweet, sets.visible_decaying]).tolist())
        assert {pose["source_id"] for pose in record["poses"]} <= {fls}
        assert {pose["target_id"] for pose in record["poses"]} <= near
        assert isinstance(record["header"]["frame_id"], str)
    # Closed: the client's node and context are gone, and it says so.
    with pytest.raises(RunError, match="closed"):
        swarm.neighbours(source)


def test_a_client_of_no_swarm_says_so_within_its_timeout(domain):
    # An hour's timeout: an answer within the test's deadline came from seeing no swarm.
    with (
        api.connect("swarm", domain_id=domain, timeout=3600.0) as swarm,
        pytest.raises(RunError, match=f"no coordinator on domain {domain}"),
    ):
        swarm.compute_pose(0, 2)


def test_a_client_refuses_a_namespace_that_is_not_one(domain):
    with pytest.raises(OptionError, match="namespace 'bad name!'"):
        api.connect("bad name!", domain_id=domain)


def test_a_swarm_spawned_here_is_served_while_its_client_asks_and_stopped_when_it_closes(
    domain,
):
    cloud, scale, beta = SHAPE
    spec = api.WorldSpec(cloud, scale=scale, beta=beta)
    world = spec.build()
    engine = evaluate_pairs(world.hood, "fewest-hops")
    pair = int(np.flatnonzero(engine.hops >= 2)[-1])
    source, target = int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]])
    with api.spawn(spec, domain_id=domain, timeout=PATIENCE) as swarm:
        running = swarm._swarm
        assert swarm.neighbours(source).blind == tuple(world.neighbours(source).blind.tolist())
        found = swarm.compute_pose(source, target, policy="fewest-hops")
        assert found.path == tuple(int(world.ids[k]) for k in engine.path(pair))
        np.testing.assert_allclose(found.vector, engine.estimate[pair], rtol=0, atol=1e-9)
        assert len(swarm.echo("measurements", count=2)) == 2
        computed = swarm.compute_all("fewest-hops")
        assert computed.record.comparison.identical
        assert computed.record.summary.pairs.blind_pairs == len(engine)
    # Closed: the swarm's nodes and context are gone with the client's.
    assert not running.context.ok() and not running.host.nodes


def test_compute_all_is_swazure_spawn_compute_all_and_equals_the_engine(domain):
    cloud, scale, beta = SHAPE
    computed = api.compute_all(api.WorldSpec(cloud, scale=scale, beta=beta), domain_id=domain)
    record = computed.record
    assert record.comparison.identical
    assert record.distributed is not None and record.distributed.rounds > 0
    engine = api.evaluate(api.build_swarm(cloud, scale=scale, beta=beta)).summary
    assert record.summary is not None
    assert record.summary.pairs.blind_pairs == engine.pairs.blind_pairs > 10_000
    assert record.summary.pairs.sweet_pairs == engine.pairs.sweet_pairs
    assert record.summary.pairs.no_path_pairs == engine.pairs.no_path_pairs
