"""Tracking over ROS 2: FLS nodes on a simulated clock relay a moving target to a source.

The swarm: source 0 at the origin, relay 1 in its sweet range, target 2
blind to the source and in the relay's sweet range (r = 0.5 cm), as in
test/core/test_tracking.py.
"""

import numpy as np
import pytest
from swazure_interfaces.srv import TrackTarget

from swazure_ros.app.track import TrackSession, run_track, same_run
from swazure_ros.core.clouds import Cloud
from swazure_ros.core.estimators import CONSTANT_ACCELERATION, TrackingError
from swazure_ros.core.frames import to_metres
from swazure_ros.core.motion import Motion
from swazure_ros.core.tracking import TIMED_OUT, TRACKING, TrackConfig, nanoseconds
from swazure_ros.files.sensors import load_sensor
from swazure_ros.files.trajectories import parse_trajectory
from swazure_ros.protocol.loops import simulate_track
from swazure_ros.ros.convert.tracking import motion_estimate as estimate_from_message
from swazure_ros.sim.world import make_world

from ...waits import PATIENCE, wait_until

HOME = np.array([[0.0, 0.0, 0.0], [8.0, 0.0, 0.0], [2.5, 5.5, 0.0]])
CIRCLE = Motion({2: parse_trajectory("circle:0.5,4,-1,1,0")})


@pytest.fixture(scope="module")
def world():
    return make_world(Cloud("trio", HOME, 1.0, "test"), load_sensor(), radius=0.5)


def test_a_track_over_ros_equals_the_core_loop(world, domain):
    config = TrackConfig(sensing_delay=0.1, communication_delay=0.2)
    ours = run_track(world, CIRCLE, 0, 2, config, 3.0, domain_id=domain)
    core = simulate_track(
        world.sensor, world.swarm.points, world.ids, world.swarm.radius, CIRCLE, 0, 2, config, 3.0
    )
    assert ours.relay == core.relay == 1
    assert len(ours.estimates) == len(core.estimates) == 31
    # The messages carry metres: each state equals the loop's in metres, to the bit.
    for got, expected in zip(ours.estimates, core.estimates, strict=True):
        assert got.status == expected.status == TRACKING
        assert got.time == expected.time
        assert got.sample_time == expected.sample_time
        assert np.array_equal(to_metres(got.kalman.position), to_metres(expected.kalman.position))
        assert np.array_equal(
            to_metres(got.kalman.acceleration), to_metres(expected.kalman.acceleration)
        )
        assert np.array_equal(
            to_metres(got.difference_velocity),
            to_metres(expected.difference_velocity),
            equal_nan=True,
        )
    assert same_run(ours, core)


def tick_until(session, seconds, step):
    for now in range(step, nanoseconds(seconds) + 1, step):
        session.advance(now)


def test_when_the_relay_stops_the_stream_times_out_and_ends(world, context):
    config = TrackConfig(timeout=0.5)
    session = TrackSession(world, CIRCLE, [0, 1, 2], config, context=context)
    try:
        session.start()
        assert session.track(0, 2, CONSTANT_ACCELERATION) == 1
        step = nanoseconds(config.frame_period)
        tick_until(session, 1.0, step)
        session.spin_until(lambda: len(session.client.estimate_messages) >= 11, PATIENCE)
        assert [message.status for message in session.client.estimate_messages[:11]] == [1] * 11
        session.stop_fls(1)
        for now in range(nanoseconds(1.0) + step, nanoseconds(3.0) + 1, step):
            session.advance(now)

        def received() -> list:
            return [estimate_from_message(one) for one in session.client.estimate_messages]

        session.spin_until(lambda: TIMED_OUT in [one.status for one in received()], PATIENCE)
        estimates = received()
        statuses = [estimate.status for estimate in estimates]
        # One final word, then silence: no extrapolation for ever.
        assert statuses.count(TIMED_OUT) == 1
        assert statuses[-1] == TIMED_OUT
        last = estimates[-1]
        assert last.kalman is None
        assert "no sample for" in last.message
        assert 1.5 < last.time <= 1.0 + config.timeout + 2 * config.frame_period
        count = len(session.client.estimate_messages)
        tick_until(session, 4.0, step)
        assert len(session.client.estimate_messages) == count
    finally:
        session.close()


def test_a_session_waits_while_the_swarm_makes_progress_and_gives_up_after_silence(world, context):
    import time

    session = TrackSession(world, CIRCLE, [0, 1, 2], TrackConfig(), context=context)
    try:
        session.start()
        before = session.progress()
        assert session.track(0, 2, CONSTANT_ACCELERATION) == 1
        tick_until(session, 0.5, nanoseconds(TrackConfig().frame_period))
        # The swarm's work shows: counts that only grow, and some grew.
        after = session.progress()
        assert after != before and all(a >= b for a, b in zip(after, before, strict=True))
        # News keeps the wait going past its timeout: 1 s of it, then 0.3 s of silence.
        began = time.monotonic()
        news = iter(range(1_000_000))
        moving = lambda: next(news) if time.monotonic() - began < 1.0 else -1  # noqa: E731
        assert not session.spin_until(lambda: False, 0.3, moving)
        assert time.monotonic() - began >= 1.3
        # Without news, the timeout is the whole wait.
        began = time.monotonic()
        assert not session.spin_until(lambda: False, 0.3, lambda: 0)
        assert time.monotonic() - began >= 0.3
    finally:
        session.close()


def test_requests_it_cannot_serve_get_an_error_and_the_node_keeps_serving(world, context):
    session = TrackSession(world, CIRCLE, [0, 1, 2], TrackConfig(), context=context)
    try:
        session.start()
        with pytest.raises(TrackingError, match="no FLS 7 in this swarm"):
            session.track(0, 7, CONSTANT_ACCELERATION)
        with pytest.raises(TrackingError, match="no sweet neighbour of FLS 0 sees FLS 1"):
            session.track(0, 1, CONSTANT_ACCELERATION)
        client = session.client.create_client(TrackTarget, "fls_0/track")
        for request, message in (
            (TrackTarget.Request(source_id=0, target_id=2, model=7), "unknown model 7"),
            (TrackTarget.Request(source_id=1, target_id=2, model=1), "this is FLS 0"),
        ):
            future = client.call_async(request)
            assert session.spin_until(future.done, PATIENCE)
            assert not future.result().success
            assert message in future.result().message
        assert session.track(0, 2, CONSTANT_ACCELERATION) == 1
    finally:
        session.close()


def test_swazure_track_over_ros_says_it_matches_the_core(domain, tmp_path):
    import subprocess
    import sys

    cloud = tmp_path / "trio.xyz"
    cloud.write_text("\n".join(" ".join(str(value) for value in row) for row in HOME) + "\n")
    run = subprocess.run(
        [
            sys.executable, "-m", "swazure_ros.cli.main", "track", "--cloud", str(cloud),
            "--scale", "1", "--radius", "0.5", "--source", "0", "--target", "2",
            "--trajectory", "linear:0,0,0.2", "--duration", "2", "--sensing-delay", "0.1",
            "--domain-id", str(domain),
        ],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "through relay FLS 1" in run.stdout
    assert "identical to the core's loop: yes" in run.stdout


def test_a_handover_to_another_relay_over_ros_equals_the_core_loop(domain):
    home = np.vstack([HOME, [[-5.0, 6.0, 0.0], [-1.25, 5.75, 1.0]]])
    world = make_world(Cloud("handover", home, 1.0, "test"), load_sensor(), radius=0.5)
    motion = Motion({2: parse_trajectory("linear:0,0,0.4")})
    config = TrackConfig(communication_delay=0.2)
    ours = run_track(world, motion, 0, 2, config, 5.0, domain_id=domain)
    core = simulate_track(
        world.sensor, world.swarm.points, world.ids, world.swarm.radius, motion, 0, 2, config, 5.0
    )
    assert [estimate.relay for estimate in ours.estimates] == [
        estimate.relay for estimate in core.estimates
    ]
    assert {estimate.relay for estimate in ours.estimates} == {1, 3}
    assert [estimate.sample_time for estimate in ours.estimates] == [
        estimate.sample_time for estimate in core.estimates
    ]
    assert np.array_equal(  # in metres, as the messages carry them
        to_metres(np.array([estimate.kalman.velocity for estimate in ours.estimates])),
        to_metres(np.array([estimate.kalman.velocity for estimate in core.estimates])),
    )


def test_a_swarm_on_the_wall_clock_tracks_too(world, context):
    # As under `swazure spawn` with the track service on: no simulated clock,
    # the relay's camera on a wall timer.
    from rclpy.node import Node
    from swazure_interfaces.msg import TrackEstimate

    from swazure_ros.ros.programs.host import HostConfig, SwarmHost

    track = {"track.frame_period": 0.05, "track.service": True}
    with SwarmHost(world, HostConfig((0, 1, 2), parameters=track), context=context) as host:
        host.create_fls_nodes()
        client = Node("probe", namespace="swarm", context=context)
        host.add(client)
        received = []
        client.create_subscription(TrackEstimate, "track_estimates", received.append, 100)
        service = client.create_client(TrackTarget, "fls_0/track")
        assert host.spin_until_discovered(PATIENCE)
        future = service.call_async(TrackTarget.Request(source_id=0, target_id=2, model=1))
        # On the wall clock: spins return early when there is work, so they are no measure.
        assert wait_until(future.done, PATIENCE, lambda: host.spin_once(0.05))
        assert future.result().success
        # Twenty frames of 0.05 s, however long a busy machine takes to show them.
        assert wait_until(lambda: len(received) >= 20, PATIENCE, lambda: host.spin_once(0.05))
        assert {message.relay_id for message in received} == {1}
        assert all(message.status == TrackEstimate.STATUS_TRACKING for message in received)
        # The target is still: the relayed position is its home, the velocity nil.
        last = estimate_from_message(received[-1])
        assert np.allclose(last.raw, HOME[2] - HOME[0], atol=0.1)
        assert np.linalg.norm(last.kalman.velocity) < 1e-6


def test_on_the_wall_clock_an_fls_with_nothing_to_relay_or_track_stops_its_frames(world, context):
    # A flood of requests reaches many relays: each must not tick for ever once its
    # stream is stopped (here, by a STOP that anyone may send, and the track's timeout).
    from rclpy.node import Node
    from swazure_interfaces.msg import TrackRequest

    from swazure_ros.ros.plumbing.names import ROUND_QOS, TRACK_REQUESTS_TOPIC
    from swazure_ros.ros.programs.host import HostConfig, SwarmHost

    track = {"track.frame_period": 0.05, "track.service": True, "track.timeout": 0.5}
    with SwarmHost(world, HostConfig((0, 1, 2), parameters=track), context=context) as host:
        host.create_fls_nodes()
        client = Node("probe", namespace="swarm", context=context)
        host.add(client)
        service = client.create_client(TrackTarget, "fls_0/track")
        requests = client.create_publisher(TrackRequest, TRACK_REQUESTS_TOPIC, ROUND_QOS)
        assert host.spin_until_discovered(PATIENCE)
        future = service.call_async(TrackTarget.Request(source_id=0, target_id=2, model=1))
        source, relay = (next(n for n in host.fls_nodes if n.fls_id == k) for k in (0, 1))

        def spin_until(condition) -> bool:
            return wait_until(condition, PATIENCE, lambda: host.spin_once(0.05))

        assert spin_until(future.done) and future.result().success
        assert spin_until(lambda: requests.get_subscription_count() >= 1)
        assert spin_until(lambda: len(relay.tracking.relay) == 1)
        assert source.tracking.ticking and relay.tracking.ticking
        requests.publish(TrackRequest(command=TrackRequest.COMMAND_STOP, source_id=0,
                                      relay_id=1, target_id=2))  # fmt: skip
        assert spin_until(lambda: not relay.tracking.ticking and not source.tracking.ticking)
        assert len(relay.tracking.relay) == 0 and not source.tracking.tracker.tracks


def test_an_fls_reporting_progress_reports_first_once_every_peer_hears_its_requests(
    world, context
):
    # Under a driver of the clock in another process (swazure track --per-fls): a
    # request sent before a peer's reader matched is lost, so the FLS's first report,
    # which the driver starts on, waits for track.peers readers of its requests.
    from rclpy.node import Node
    from swazure_interfaces.msg import TrackRequest, TrackSample

    from swazure_ros.ros.clients.track_client import TrackClient
    from swazure_ros.ros.plumbing.names import (
        ROUND_QOS,
        TRACK_REQUESTS_TOPIC,
        TRACK_SAMPLES_TOPIC,
    )
    from swazure_ros.ros.programs.host import HostConfig, SwarmHost

    track = {"track.report_progress": True, "track.peers": 2, "use_sim_time": True}
    with SwarmHost(world, HostConfig((0,), parameters=track), context=context) as host:
        host.create_fls_nodes()
        [fls] = host.fls_nodes
        client = TrackClient(namespace="swarm", context=context, ids=world.ids, guard=host.guard)
        host.add(client)

        def spin_until(condition) -> bool:
            return wait_until(condition, PATIENCE, lambda: host.spin_once(0.05))

        # One peer's radio (this process's) and the driver hear it: one reader short.
        assert spin_until(lambda: client.hears(1))
        assert spin_until(lambda: fls.tracking.readers(TRACK_REQUESTS_TOPIC) == 1)
        wait_until(lambda: False, 1.0, lambda: host.spin_once(0.05))
        assert not fls.tracking.matched() and client.progress == {}
        # The second peer's radio comes up: the report follows, at time 0, nothing sent.
        peer = Node("peer_radio", namespace="swarm", context=context)
        host.add(peer)
        peer.create_subscription(TrackRequest, TRACK_REQUESTS_TOPIC, lambda _: None, ROUND_QOS)
        peer.create_subscription(TrackSample, TRACK_SAMPLES_TOPIC, lambda _: None, ROUND_QOS)
        assert spin_until(lambda: 0 in client.progress)
        report = client.progress[0]
        assert report.time == 0 and not report.due
        assert report.traffic["requests_sent"] == report.traffic["samples_sent"] == 0
        assert fls.tracking.matched() and fls.tracking.ticking


def test_an_estimate_survives_the_message_round_trip(world):
    from swazure_ros.core.estimators import KalmanTracker
    from swazure_ros.core.tracking import Track
    from swazure_ros.protocol.tracking import TrackReport
    from swazure_ros.ros.convert.tracking import track_estimate_message

    track = Track(KalmanTracker(), timeout=1.0, relay=1)
    waiting = track_estimate_message(TrackReport(0, 2, CONSTANT_ACCELERATION, track.estimate(0.0)))
    assert np.isnan(estimate_from_message(waiting).sample_time)
    track.add(0.0, np.array([1.0, 2.0, 3.0]))  # sensed at t = 0, a real time on /clock
    track.end("the relay lost sight of the target")
    ended = track.estimate(0.2)
    back = estimate_from_message(
        track_estimate_message(TrackReport(0, 2, CONSTANT_ACCELERATION, ended))
    )
    assert (back.status, back.time, back.sample_time, back.relay) == ("ended", 0.2, 0.0, 1)
    assert np.array_equal(back.raw, [1.0, 2.0, 3.0])
    assert back.kalman is None
    assert back.message == ended.message
