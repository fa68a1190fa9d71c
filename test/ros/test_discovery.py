"""Path discovery between FLS nodes over real DDS, against the core engine."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from swazure_interfaces.msg import PoseEstimate
from swazure_interfaces.srv import ComputePose

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.evaluate import evaluate, evaluate_pairs
from swazure_ros.core.evaluation import NO_PATH
from swazure_ros.core.fit import LOCAL_LEAST_SQUARES, refine
from swazure_ros.core.frames import fls_frame, to_metres
from swazure_ros.core.heuristics.folding import run_technique
from swazure_ros.core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE
from swazure_ros.core.neighbourhood import without
from swazure_ros.files.reading import config_dir
from swazure_ros.files.record import RECORD_FILE, read_record
from swazure_ros.files.results import read_pairs
from swazure_ros.protocol.discovery.estimate import Estimate
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.ros.convert.discovery import pose_estimate_from_message
from swazure_ros.ros.plumbing.names import ESTIMATOR_CODES, policy_code
from swazure_ros.sim.world import WorldSpec

from ..conftest import source_body_scene
from ..waits import PATIENCE, wait_until

# torus:120 at 1.6 x has sweet, blocked and unreachable pairs at both betas.
SHAPE = ("torus:120", 1.6)
POLICIES = ("fewest-hops", "shortest-length")
# Least-error's labels carry their summed hop errors over DDS (PathOffer.errors).
DISCOVERY_POLICIES = (*POLICIES, "least-error")
CALIBRATED = str(config_dir() / "cameras" / "sensor-wide-calibrated.yaml")
LOCAL_LEAST_SQUARES_CODE = ESTIMATOR_CODES[LOCAL_LEAST_SQUARES]
SPAWN_TIMEOUT = 600  # s: a whole swarm's bring-up, run and teardown on a busy machine


@pytest.fixture
def params(tmp_path):
    """Slow measurement messages (discovery does not need them).

    The round timeout is the product's default: an FLS stopped in these tests leaves the
    graph, and the graph, not silence, makes it depart. A short timeout would take a slow
    FLS for a departed one on a busy machine, and the run's pairs for another swarm's.
    """
    path = tmp_path / "swarm.yaml"
    path.write_text("/**:\n  ros__parameters:\n    publish_period: 5.0\n")
    return path


def swarm_of(domain, params, beta=0.5):
    world = WorldSpec(SHAPE[0], scale=SHAPE[1], beta=beta)
    return RunningSwarm.start(SwarmConfig(world, domain_id=domain, params_file=str(params)))


def by_pair(estimates: dict[int, list[Estimate]]) -> dict[tuple[int, int], Estimate]:
    return {(source, one.target): one for source, found in estimates.items() for one in found}


def assert_matches_engine(world, found, engine):
    """Every engine pair was reported with the engine's status, hops, path and estimate."""
    ids = world.ids
    assert len(found) == len(engine)
    for pair in range(len(engine)):
        source, target = int(ids[engine.source[pair]]), int(ids[engine.target[pair]])
        one = found[(source, target)]
        assert (one.status, one.reason, one.hops) == (
            engine.status[pair],
            engine.reason[pair],
            engine.hops[pair],
        ), (source, target)
        assert one.path == tuple(int(ids[k]) for k in engine.path(pair)), (source, target)
        if one.status != NO_PATH:
            np.testing.assert_allclose(one.vector, engine.estimate[pair], rtol=0, atol=1e-9)


def assert_moves_match_engine(moved, engine, plan):
    """The swarm's moves resolved the engine's pairs, with its paths and estimates."""
    ours, theirs = moved.outcome.evaluation.pairs, engine.pairs
    np.testing.assert_array_equal(ours.status, theirs.status)
    np.testing.assert_array_equal(ours.hops, theirs.hops)
    np.testing.assert_array_equal(ours.offsets, theirs.offsets)
    np.testing.assert_array_equal(ours.nodes, theirs.nodes)
    np.testing.assert_allclose(ours.estimate, theirs.estimate, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(moved.outcome.heuristic.resolved, plan.resolved)


@pytest.mark.parametrize("beta", [0.3, 0.5])
def test_whole_swarm_discovery_equals_the_engine(domain, params, beta):
    with swarm_of(domain, params, beta) as swarm:
        world = swarm.world
        for policy in DISCOVERY_POLICIES:
            result = swarm.discover(policy, timeout=300)
            engine = evaluate_pairs(world.hood, policy)
            assert len(engine) > 10_000 and (engine.reason > 0).sum() > 1000
            assert result.outcome.departed == frozenset() and result.outcome.restarts == 0
            assert_matches_engine(world, by_pair(result.outcome.estimates), engine)
            # Each FLS broadcasts once a round and every source reports once.
            offers = result.traffic.messages["radio"]
            assert offers == result.outcome.rounds * len(world.ids)
            assert result.traffic.messages["estimates"] == len(world.ids)


# Each technique at one beta and one policy, both betas and both policies covered: a
# technique's run (plain, moves, plain again) takes about 45 s over DDS. The same move
# machine runs both techniques in memory (test/protocol/test_moves.py), and two processes
# make both over DDS (test/ros/test_cells.py).
@pytest.mark.parametrize(
    ("technique", "beta", "policy"),
    [(MOVE_OBSTRUCTING, 0.5, "fewest-hops"), (MOVE_SOURCE, 0.3, "shortest-length")],
)
def test_moves_made_by_the_swarm_equal_the_engine_and_a_watching_person_sees_each(
    domain, params, technique, beta, policy
):
    with swarm_of(domain, params, beta) as swarm:
        world = swarm.world
        plain = swarm.discover(policy, timeout=300)
        found = evaluation_of(world.hood, policy, plain.outcome.estimates)
        with watching_moves(swarm) as printed:
            moved = swarm.make_moves(found, technique, threshold=10, timeout=300)
            commands = moved.outcome.moved
            # Reliable, and matched before the first move: every command reaches the
            # watch; the echo prints far slower than the swarm moves.
            wait_until(lambda: printed.text.count("fls_id:") >= commands, PATIENCE)
        watched = printed.text
        assert commands > 200 and watched.count("fls_id:") == commands, printed.err
        # Moves of the technique's kind and returns, each command once.
        kind = "kind: 0" if technique == MOVE_OBSTRUCTING else "kind: 1"
        assert watched.count(kind) + watched.count("kind: 2") == commands, watched[:2000]
        assert watched.count(kind) > 0 and watched.count("kind: 2") > 0, watched[:2000]
        assert "commands:" in watched and "displacement:" in watched
        engine, plan = run_technique(
            evaluate(world.swarm, world.sensor, policy), technique, threshold=10
        )
        assert plan.resolved.sum() > 500
        assert (
            moved.outcome.walks == plan.resolved.sum()
            and moved.outcome.batches < moved.outcome.walks / 5
        )
        assert_moves_match_engine(moved, engine, plan)
        # Every FLS is back at its point: the next run is the plain run again.
        assert (swarm.host.replica.world.swarm.points == world.swarm.points).all()
        before = by_pair(plain.outcome.estimates)
        again = by_pair(swarm.discover(policy, timeout=300).outcome.estimates)
        assert again.keys() == before.keys()
        assert all(one.path == before[key].path for key, one in again.items())


def test_a_node_stopped_mid_run_departs_and_paths_avoid_it(domain, params):
    policy = "shortest-length"
    with swarm_of(domain, params) as swarm:
        world = swarm.world
        engine = evaluate_pairs(world.hood, policy)
        # Stop the FLS that relays the most of the engine's paths.
        inner = np.concatenate([engine.path(pair)[1:-1] for pair in range(len(engine))])
        stopped_index = int(np.bincount(inner.astype(np.int64)).argmax())
        stopped = int(world.ids[stopped_index])
        fls = swarm.host.fls_by_id[stopped]

        def stop_mid_run():
            # Once the FLS has broadcast twice, its software stops mid-run.
            if stopped in swarm.host.fls_by_id and fls.messages_sent >= 2:
                swarm.host.stop_fls(stopped)

        # A run that waited on the stopped FLS for ever would raise TimeoutError here.
        result = swarm.run(swarm.coordinator.discover(policy), timeout=PATIENCE, step=stop_mid_run)
        assert stopped not in swarm.host.fls_by_id
        assert result.outcome.departed == frozenset({stopped}) and result.outcome.restarts >= 1
        assert stopped not in result.outcome.estimates
        found = by_pair(result.outcome.estimates)
        assert not [pair for pair in found if stopped in pair]
        expected = evaluate_pairs(without(world.hood, np.array([stopped_index])), policy)
        keep = (expected.source != stopped_index) & (expected.target != stopped_index)
        changed = 0
        ids = world.ids
        for pair in np.flatnonzero(keep).tolist():
            source, target = int(ids[expected.source[pair]]), int(ids[expected.target[pair]])
            one = found[(source, target)]
            assert (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
            assert one.path == tuple(int(ids[k]) for k in expected.path(pair))
            if one.status != NO_PATH:
                np.testing.assert_allclose(one.vector, expected.estimate[pair], atol=1e-9)
            changed += one.path != tuple(int(ids[k]) for k in engine.path(pair))
        assert len(found) == int(keep.sum())
        assert changed > 0  # the stopped FLS mattered

        # The swarm goes on without it: the next run needs no restart.
        again = swarm.discover(policy, timeout=PATIENCE)
        assert (
            again.outcome.restarts == 0 and by_pair(again.outcome.estimates).keys() == found.keys()
        )


def test_nodes_stopped_mid_run_are_known_gone_at_once_not_after_a_round_timeout(domain, tmp_path):
    # A round timeout of an hour, far past the run's deadline below: if the run ends, the
    # graph, not a round's timeout, made the stopped FLSs depart.
    params = tmp_path / "swarm.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    publish_period: 5.0\n"
        "/**/coordinator:\n  ros__parameters:\n    round_timeout: 3600.0\n"
        "    liveness_period: 0.2\n"
    )
    policy = "shortest-length"
    with swarm_of(domain, params) as swarm:
        world = swarm.world
        # 5 % of the FLSs, spread over the shape (seeded), stop once each has spoken twice.
        stopped_index = np.sort(np.random.default_rng(5).choice(len(world.ids), 6, replace=False))
        stopped = {int(world.ids[k]) for k in stopped_index}
        nodes = {fls: swarm.host.fls_by_id[fls] for fls in stopped}
        heard = []
        probe = Node("departed_probe", context=swarm.context, start_parameter_services=False)
        from swazure_interfaces.msg import Departed

        from swazure_ros.ros.plumbing.names import DEPARTED_QOS

        probe.create_subscription(Departed, "/swarm/departed", heard.append, DEPARTED_QOS)
        swarm.host.add(probe)

        def stop_mid_run():
            if all(node.messages_sent >= 2 for node in nodes.values()):
                for fls in stopped & set(swarm.host.fls_by_id):
                    swarm.host.stop_fls(fls)

        run = swarm.coordinator.discover(policy)
        result = swarm.run(run, timeout=PATIENCE, step=stop_mid_run)
        assert result.outcome.departed == frozenset(stopped) and result.outcome.restarts >= 1
        expected = evaluate_pairs(without(world.hood, stopped_index), policy)
        found = by_pair(result.outcome.estimates)
        keep = ~np.isin(expected.source, stopped_index) & ~np.isin(expected.target, stopped_index)
        ids = world.ids
        for pair in np.flatnonzero(keep).tolist():
            source, target = int(ids[expected.source[pair]]), int(ids[expected.target[pair]])
            one = found[(source, target)]
            assert (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
            assert one.path == tuple(int(ids[k]) for k in expected.path(pair))
        assert len(found) == int(keep.sum())
        # Who is gone is on /swarm/departed for anyone to read.
        assert wait_until(
            lambda: heard and sorted(heard[-1].fls_ids) == sorted(stopped),
            PATIENCE,
            lambda: swarm.spin(0.1),
        ), heard[-1:]
        # And every FLS knows which of its own neighbours are gone.
        from swazure_interfaces.srv import GetNeighbours

        asked = next(
            fls for fls in swarm.host.fls_by_id if stopped & set(world.view(fls).other.tolist())
        )
        client = probe.create_client(GetNeighbours, f"/swarm/fls_{asked}/get_neighbours")
        while not client.service_is_ready():
            swarm.spin(0.05)

        def ask():
            future = client.call_async(GetNeighbours.Request(fls_id=asked))
            while not future.done():
                swarm.spin(0.05)
            return future.result()

        # The host keeps its own clock of absences: a look or two after the coordinator's.
        answers = [ask()]
        wait_until(
            lambda: answers[-1].gone_ids,
            PATIENCE,
            lambda: (swarm.spin(0.5), answers.append(ask())),
        )
        answer = answers[-1]
        known = {*answer.blind_ids, *answer.sweet_ids, *answer.decaying_ids}
        assert set(answer.gone_ids) == stopped & known and answer.gone_ids


def test_a_lost_coordinator_aborts_every_source_and_a_new_one_runs_again(domain, params):
    from swazure_interfaces.msg import PoseEstimates

    from swazure_ros.core.evaluation import ABORTED, REASON_COORDINATOR_LOST
    from swazure_ros.ros.nodes.coordinator import Coordinator
    from swazure_ros.ros.plumbing.names import ROUND_QOS

    policy = "shortest-length"
    with swarm_of(domain, params) as swarm:
        world = swarm.world
        engine = evaluate_pairs(world.hood, policy)
        aborted = {}
        probe = Node("estimates_probe", context=swarm.context, start_parameter_services=False)

        def on_estimates(message):
            for target, status, reason in zip(
                message.target_ids, message.statuses, message.reasons, strict=True
            ):
                if status == ABORTED:
                    assert reason == REASON_COORDINATOR_LOST
                    aborted[(message.source_id, int(target))] = message.run_id

        probe.create_subscription(PoseEstimates, "/swarm/estimates", on_estimates, ROUND_QOS)
        swarm.host.add(probe)
        run = swarm.coordinator.discover(policy)
        relay = swarm.host.fls_nodes[0]
        while relay.messages_sent < 2:  # the run is under way
            swarm.host.spin_once(0.02)
        lost = swarm.coordinator
        swarm.host.executor.remove_node(lost)
        swarm.host.nodes.remove(lost)
        lost.destroy_node()  # as a crash: no END, no answer
        wait_until(
            lambda: len(aborted) >= len(engine), PATIENCE, lambda: swarm.host.spin_once(0.05)
        )
        assert not run.done()
        # Every source's every target has a clear status, and nothing else does.
        ids = world.ids
        expected = {(int(ids[s]), int(ids[t])) for s, t in zip(engine.source, engine.target)}
        assert set(aborted) == expected
        assert swarm.host.aborted == len(engine)

        # A coordinator started again runs from scratch, as the engine does.
        swarm.coordinator = Coordinator(
            ids.tolist(),
            hosts=1,
            shape=world.swarm,
            sensor=world.sensor,
            namespace="swarm",
            context=swarm.context,
            key=swarm.key,
        )
        swarm.host.add(swarm.coordinator)
        result = swarm.discover(policy, timeout=PATIENCE)
        assert result.run_id != next(iter(aborted.values()))
        assert_matches_engine(world, by_pair(result.outcome.estimates), engine)


@pytest.mark.parametrize(
    ("loss", "attempts", "delay", "complete"),
    [(0.1, 12, 0.0, True), (0.1, 12, 0.1, True), (0.6, 1, 0.0, False)],
    ids=["repaired", "repaired-late", "lost"],
)
def test_a_lossy_radio_gives_the_engines_results_or_says_incomplete(
    domain, tmp_path, loss, attempts, delay, complete
):
    params = tmp_path / "swarm.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    publish_period: 5.0\n"
        f"    radio:\n      loss: {loss}\n      seed: 7\n      attempts: {attempts}\n"
        f"      delay: {delay}\n"
    )
    policy = "shortest-length"
    with swarm_of(domain, params) as swarm:
        began = time.monotonic()
        result = swarm.discover(policy, timeout=PATIENCE)
        # Each round's ack waits for its last delivery (repaired ones past 0.1 s): a torus
        # round takes well under 0.1 s on a perfect radio. A lower bound only, which a busy
        # machine can only make truer: the delay is applied, however slow the machine.
        assert delay == 0 or time.monotonic() - began > result.outcome.rounds * delay
        if complete:
            # Every lost delivery was asked for again: the same results as a perfect radio.
            assert not result.outcome.incomplete and result.outcome.repairs > 0
            engine = evaluate_pairs(swarm.world.hood, policy)
            assert_matches_engine(swarm.world, by_pair(result.outcome.estimates), engine)
        else:
            # Lost for good, phase after phase: no estimates rather than worse ones.
            assert (
                result.outcome.incomplete
                and result.outcome.estimates == {}
                and result.outcome.repairs == 0
            )


class Client:
    """A ComputePose client in its own context, spun alongside the swarm."""

    def __init__(self, swarm, context):
        self.swarm = swarm
        self.node = Node("probe", context=context, start_parameter_services=False)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.clients = {}

    def call(self, source, target, policy=0, estimator=0, timeout=PATIENCE, service=None):
        """Ask the coordinator's service, or ``service`` (e.g. an FLS node's)."""
        service = service or "/swarm/coordinator/compute_pose"
        if service not in self.clients:
            self.clients[service] = self.node.create_client(ComputePose, service)
        client = self.clients[service]
        assert wait_until(client.service_is_ready, timeout, self._spin), f"no {service} service"
        future = client.call_async(
            ComputePose.Request(
                source_id=source, target_id=target, policy=policy, estimator=estimator
            )
        )
        assert wait_until(future.done, timeout, self._spin), "no answer"
        return future.result()

    def _spin(self):
        self.executor.spin_once(timeout_sec=0.02)
        self.swarm.spin(0.02)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()


def test_compute_pose_answers_bad_requests_with_errors_and_keeps_working(domain, params, context):
    with swarm_of(domain, params) as swarm:
        world = swarm.world
        engine = evaluate_pairs(world.hood, "fewest-hops")
        pair = int(np.flatnonzero(engine.hops >= 2)[0])
        source, target = int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]])
        not_blind = int(world.neighbours(source).sweet[0])
        client = Client(swarm, context)
        try:
            for request, message in [
                ((source, 5000), "no target FLS 5000"),
                ((5000, target), "no source FLS 5000"),
                ((source, source), f"source and target are both FLS {source}"),
                ((source, target, 7), "unknown policy 7"),
                ((source, target, 0, 9), "unknown estimator 9"),
                ((source, not_blind), "not a blind neighbour"),
            ]:
                response = client.call(*request)
                assert not response.success and message in response.message, response.message
                # A refusal carries no estimate, and its status says so (0 is SWEET).
                assert response.estimate.status == PoseEstimate.STATUS_NONE
            response = client.call(source, target, policy_code("fewest-hops"))
            assert response.success, response.message
            one = pose_estimate_from_message(response.estimate)
            assert (one.target, one.status, one.hops) == (
                target,
                engine.status[pair],
                engine.hops[pair],
            )
            assert one.path == tuple(int(world.ids[k]) for k in engine.path(pair))
            # The answer is in metres (REP-103), in the source's frame: the engine's
            # centimetres, converted once, to the bit.
            answered = response.estimate.vector
            assert response.estimate.header.frame_id == fls_frame(source)
            np.testing.assert_array_equal(
                [answered.x, answered.y, answered.z], to_metres(engine.estimate[pair])
            )
            # After the errors the service still answers, and the same each time.
            again = client.call(source, target, policy_code("fewest-hops"))
            assert again.success, again.message
            twice = pose_estimate_from_message(again.estimate)
            assert (twice.path, twice.status) == (one.path, one.status)
            np.testing.assert_array_equal(twice.vector, one.vector)
        finally:
            client.close()


def swazure(*args):
    return subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


class Printed:
    """What a watching ``swazure echo`` printed so far (``text``), and its stderr once
    it ended (``err``)."""

    def __init__(self) -> None:
        self.parts: list[str] = []
        self.err = ""

    @property
    def text(self) -> str:
        return "".join(self.parts)


@contextlib.contextmanager
def watching_moves(swarm):
    """A person's ``swazure echo /swarm/move_commands`` while ``swarm`` runs, its output.

    The watch counts as up once the coordinator's graph lists its reader and the
    coordinator's move publisher has matched one reader more than the swarm's own:
    commands are reliable and kept until every matched reader has them, so each one
    sent after that reaches the watch, however late its half of the discovery ends.
    (Started alongside a whole `spawn --compute-all` instead, the watch saw nothing in
    some loaded runs: the run's moves were over before the two processes had found
    each other.) On leaving, the watch must still be running
    (it neither failed nor gave up), and end by SIGTERM without a traceback.
    """
    moves = swarm.coordinator.outbox.moves
    own = moves.get_subscription_count()  # the swarm's own readers: world and cameras
    watch = swazure("echo", "/swarm/move_commands")
    printed = Printed()
    # Read as it prints: an echo blocked on a full pipe (64 KiB, about ten messages
    # of moves) prints no more.
    reader = threading.Thread(target=lambda: printed.parts.extend(watch.stdout), daemon=True)
    reader.start()
    try:
        coordinator = swarm.coordinator

        def watch_matched():
            readers = coordinator.get_subscriptions_info_by_topic("/swarm/move_commands")
            listed = any(one.node_name == "swazure_echo" for one in readers)
            return listed and moves.get_subscription_count() > own

        matched = wait_until(
            lambda: watch_matched() or watch.poll() is not None, PATIENCE, lambda: swarm.spin(0.1)
        )
        assert matched and watch.poll() is None, "the watch never matched the coordinator"
        yield printed
    finally:
        watching = watch.poll() is None
        watch.terminate()
        watch.wait(timeout=PATIENCE)
        reader.join(timeout=PATIENCE)
        printed.err = watch.stderr.read()
        watch.stdout.close()
        watch.stderr.close()
    assert watching and watch.returncode == -signal.SIGTERM, printed.err
    assert "Traceback" not in printed.err, printed.err


@pytest.mark.parametrize(
    ("technique", "runs", "pairs"),
    [("plain", [], "csv"), ("plain", ["--sources-per-run", "40"], "parquet"),
     ("move-obstructing", [], "csv"), ("move-source", [], "csv")],
    ids=["plain", "plain-in-source-blocks-parquet", "move-obstructing", "move-source"],
)  # fmt: skip
def test_spawn_compute_all_writes_what_evaluate_writes(
    domain, params, tmp_path, technique, runs, pairs
):
    shape = ["--cloud", SHAPE[0], "--scale", str(SHAPE[1]), "--beta", "0.5", "--quiet"]
    shape += ["--technique", technique] + ([] if pairs == "csv" else ["--pairs", pairs])
    spawn = swazure(
        "spawn", *shape, *runs, "--params", str(params), "--compute-all",
        "--out", str(tmp_path / "d"),
    )  # fmt: skip
    evaluate = swazure("evaluate", *shape, "--out", str(tmp_path / "e"))
    try:
        out, err = spawn.communicate(timeout=300)
        assert spawn.returncode == 0, err
        record = read_record(tmp_path / "d" / RECORD_FILE)
        assert record.comparison.identical, out
        assert record.distributed is not None and record.distributed.rounds > 0
        assert (
            record.engine is not None
            and record.engine.pairs.blind_pairs == record.summary.pairs.blind_pairs
        )
        assert "distributed" in out and "engine" in out  # the table's two columns
        # Searched for in runs of 40 sources at most, one after the other.
        assert ("runs of 40 sources" in out) == bool(runs), out
        _, err = evaluate.communicate(timeout=300)
        assert evaluate.returncode == 0, err
        assert record.pairs == pairs
        distributed = (tmp_path / "d" / f"pairs.{pairs}").read_bytes()
        assert distributed == (tmp_path / "e" / f"pairs.{pairs}").read_bytes()
        assert read_pairs(tmp_path / "d").num_rows > 10_000
        moved = record.distributed.moves
        commands = 0 if moved is None else moved.move_commands
    finally:
        for process in (spawn, evaluate):
            if process.poll() is None:
                process.kill()
                process.wait()
    if technique != "plain":
        assert f"{technique}: " in out and "path walks" in out, out
        assert commands > 200, out
    else:
        assert commands == 0


def test_swazure_query_with_no_swarm_says_so_without_waiting_out_its_timeout(domain):
    # An hour's timeout: an answer within the test's deadline came from seeing no swarm.
    query = swazure("query", "--source", "0", "--target", "2", "--timeout", "3600")
    _, err = query.communicate(timeout=PATIENCE)
    # No swarm answered: the run failed (1), the command line was fine.
    assert query.returncode == 1 and len(err.strip().splitlines()) == 1, err
    assert f"no coordinator on domain {domain}, namespace /swarm" in err, err
    assert "is a swarm up?" in err


def test_swazure_query_prints_the_path_and_vector(domain, params):
    world = WorldSpec(SHAPE[0], scale=SHAPE[1], beta=0.5).build()
    engine = evaluate_pairs(world.hood, "shortest-length")
    pair = int(np.flatnonzero(engine.hops >= 2)[0])
    source, target = int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]])
    shape = ["--cloud", SHAPE[0], "--scale", str(SHAPE[1]), "--beta", "0.5", "--quiet"]
    spawn = swazure("spawn", *shape, "--params", str(params))
    try:
        line = spawn.stdout.readline()
        assert line.startswith("swarm up"), line + spawn.stderr.read()
        query = swazure("query", "--source", str(source), "--target", str(target))
        out, err = query.communicate(timeout=PATIENCE)
        assert query.returncode == 0, err
        path = " -> ".join(str(int(world.ids[k])) for k in engine.path(pair))
        assert f"path: {path} ({engine.hops[pair]} hops)" in out, out
        x, y, z = engine.estimate[pair]
        assert f"vector: ({x:.6f}, {y:.6f}, {z:.6f}) cm" in out, out
        # The source's own fit: its vector and standard deviations, cm.
        fitted = refine(
            evaluate(world.swarm, world.sensor, "shortest-length"), LOCAL_LEAST_SQUARES
        )
        query = swazure("query", "--source", str(source), "--target", str(target),
                        "--estimator", "local-least-squares")  # fmt: skip
        out, err = query.communicate(timeout=PATIENCE)
        assert query.returncode == 0, err
        pair = int(np.flatnonzero((fitted.pairs.source == engine.source[pair])
                                  & (fitted.pairs.target == engine.target[pair]))[0])  # fmt: skip
        x, y, z = fitted.pairs.estimate[pair]
        assert f"vector: ({x:.6f}, {y:.6f}, {z:.6f}) cm" in out, out
        sx, sy, sz = np.sqrt(np.diag(fitted.pairs.covariance[pair]))
        assert (
            f"local-least-squares: standard deviation (x, y, z) ({sx:.6f}, {sy:.6f}, {sz:.6f}) cm"
            in out
        ), out
        query = swazure("query", "--source", str(source), "--target", "5000")
        _, err = query.communicate(timeout=PATIENCE)
        assert query.returncode == 2 and len(err.strip().splitlines()) == 1, err
        assert "no target FLS 5000" in err and "Traceback" not in err
    finally:
        spawn.terminate()
        spawn.communicate(timeout=PATIENCE)


def test_an_error_free_swarm_refuses_least_error_and_answers_the_others(domain, params, context):
    world = WorldSpec(SHAPE[0], scale=SHAPE[1], beta=0.5, accurate=True)
    config = SwarmConfig(world, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        engine = evaluate_pairs(swarm.world.hood, "shortest-length")
        ids = swarm.world.ids
        source, target = int(ids[engine.source[0]]), int(ids[engine.target[0]])
        client = Client(swarm, context)
        try:
            refused = client.call(source, target, policy_code("least-error"))
            assert not refused.success and "least-error needs a sensor" in refused.message
            answered = client.call(source, target, policy_code("shortest-length"))
            assert answered.success, answered.message
            assert pose_estimate_from_message(answered.estimate).path == tuple(
                int(ids[k]) for k in engine.path(0)
            )
        finally:
            client.close()


def test_each_source_s_own_fit_by_the_swarm_equals_the_engine(domain, params, context):
    # A calibrated stochastic sensor: bias removed, every reading scattered. Torus:120 at
    # 2 x has sweet and decaying pairs, and 90 pairs whose path leaves the source's window
    # (the labels' sums serve them).
    world = WorldSpec(SHAPE[0], scale=2.0, beta=0.5, sensor_file=CALIBRATED)
    config = SwarmConfig(world, domain_id=domain, params_file=str(params))
    with RunningSwarm.start(config) as swarm:
        built = swarm.world
        policy = "shortest-length"
        result = swarm.discover(policy, timeout=300, estimator=LOCAL_LEAST_SQUARES)
        engine = refine(evaluate(built.swarm, built.sensor, policy), LOCAL_LEAST_SQUARES)
        assert engine.summary.fit.path_fallback_pairs > 0
        assert result.outcome.departed == frozenset() and result.outcome.restarts == 0
        found, pairs, ids = by_pair(result.outcome.estimates), engine.pairs, built.ids
        assert len(found) == len(pairs)
        fitted = 0
        for pair in np.flatnonzero(pairs.status != NO_PATH):
            one = found[(int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))]
            assert one.estimator == LOCAL_LEAST_SQUARES
            np.testing.assert_allclose(one.vector, pairs.estimate[pair], rtol=0, atol=1e-9)
            np.testing.assert_allclose(
                one.covariance, pairs.covariance[pair], rtol=0, atol=1e-9 * one.covariance.max()
            )
            fitted += 1
        assert fitted > 1000
        # The path sums too: each hop is the reading of the FLS it starts at, which its
        # first offer carried (the two ends of a pair read it differently).
        plain = swarm.discover(policy, timeout=300)
        assert_matches_engine(
            built, by_pair(plain.outcome.estimates), evaluate_pairs(built.hood, policy)
        )
        # One pair on demand: its PoseEstimate carries the covariance in m^2.
        pair = int(np.flatnonzero(pairs.status != NO_PATH)[0])
        source, target = int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]])
        client = Client(swarm, context)
        try:
            response = client.call(source, target, policy_code(policy), LOCAL_LEAST_SQUARES_CODE)
        finally:
            client.close()
        assert response.success, response.message
        assert response.estimate.estimator == LOCAL_LEAST_SQUARES_CODE
        covariance = np.asarray(response.estimate.covariance).reshape(3, 3)
        np.testing.assert_allclose(covariance * 1e4, pairs.covariance[pair], rtol=1e-9)
        answered = pose_estimate_from_message(response.estimate)
        np.testing.assert_allclose(answered.vector, pairs.estimate[pair], rtol=0, atol=1e-9)


def test_spawn_resample_brings_up_the_resampled_swarm_in_every_process(domain, params, tmp_path):
    shape = ["--cloud", "torus:60", "--scale", "5", "--beta", "0.5", "--quiet"]
    spawn = swazure(
        "spawn", *shape, "--resample", "90", "--processes", "2", "--params", str(params),
        "--compute-all", "--out", str(tmp_path / "d"),
    )  # fmt: skip
    out, err = spawn.communicate(timeout=SPAWN_TIMEOUT)
    assert spawn.returncode == 0, err
    written = tmp_path / "d" / "torus_60_resampled_90.xyz"
    assert f"resampled cloud: {written}" in out
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.bring_up is not None and record.bring_up.flss == 90
    assert record.comparison is not None and record.comparison.identical, out
    source = record.summary.parameters.source
    assert source is not None and source.cloud_source == str(written)
    assert source.resampled is not None
    assert (source.resampled.cloud, source.resampled.points, source.resampled.count) == (
        "torus_60", 60, 90,
    )  # fmt: skip
    # The file fed back is the swarm that ran: the engine's pairs are the swarm's.
    evaluate = swazure("evaluate", "--cloud", str(written), "--beta", "0.5", "--quiet",
                       "--out", str(tmp_path / "e"))  # fmt: skip
    _, err = evaluate.communicate(timeout=SPAWN_TIMEOUT)
    assert evaluate.returncode == 0, err
    assert (tmp_path / "d" / "pairs.csv").read_bytes() == (
        tmp_path / "e" / "pairs.csv"
    ).read_bytes()


@pytest.mark.parametrize("source_body", [False, True], ids=["spec-rule", "source-body"])
def test_spawn_move_source_is_the_engine_s_with_the_body_rule_and_counts_the_body_without(
    domain, params, tmp_path, source_body
):
    cloud = tmp_path / "scene.xyz"
    np.savetxt(cloud, source_body_scene(), fmt="%.17g")
    spawn = swazure(
        "spawn", "--cloud", str(cloud), "--radius", "0.5", "--quiet", "--params", str(params),
        "--compute-all", "--technique", "move-source", "--out", str(tmp_path / "d"),
        *(["--source-body"] if source_body else []),
    )  # fmt: skip
    out, err = spawn.communicate(timeout=SPAWN_TIMEOUT)
    record = read_record(tmp_path / "d" / RECORD_FILE)
    comparison = record.comparison
    assert comparison is not None
    if source_body:
        assert spawn.returncode == 0, err
        assert comparison.identical and comparison.source_body == 0, out
    else:
        # The engine's plan puts the source between the helper and the target: that one
        # pair stays BLOCKED in the swarm, and the comparison says why.
        assert spawn.returncode == 1, err
        assert (comparison.statuses, comparison.source_body) == (1, 1), out
        assert "the source's body at its probe blocks the helper's view in 1" in err
