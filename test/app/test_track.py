"""A track run whose FLSs run one to a process equals the core's loop, to the bit.

The swarm: source 0 at the origin, relay 1 in its sweet range, target 2 blind
to the source and in the relay's sweet range (config/track/trio.xyz, r = 0.5
cm), as in test/ros/nodes/test_tracking.py, which runs the same nodes in one process.
"""

from __future__ import annotations

from swazure_ros.app.track import PerFls, run_track, same_run
from swazure_ros.core.tracking import TRACKING, TrackConfig
from swazure_ros.files.trajectories import parse_motion
from swazure_ros.protocol.loops import simulate_track
from swazure_ros.sim.world import WorldSpec

from ..conftest import REPO

TRIO = WorldSpec(str(REPO / "config" / "track" / "trio.xyz"), scale=1.0, radius=0.5)
CIRCLE = "2=circle:0.5,4,-1,1,0"


def test_a_track_of_one_process_per_fls_equals_the_core_loop(domain, tmp_path):
    world, motion = TRIO.build(), parse_motion(CIRCLE)
    config = TrackConfig(sensing_delay=0.1, communication_delay=0.2)
    ours = run_track(
        world, motion, 0, 2, config, 3.0, domain_id=domain,
        per_fls=PerFls(TRIO, CIRCLE, log_dir=tmp_path),
    )  # fmt: skip
    core = simulate_track(
        world.sensor, world.swarm.points, world.ids, world.swarm.radius, motion, 0, 2, config, 3.0
    )
    assert ours.relay == core.relay == 1
    assert len(ours.estimates) == len(core.estimates) == 31
    assert {estimate.status for estimate in ours.estimates} == {TRACKING}
    assert same_run(ours, core)
    # Each FLS was a process of its own, and each ended cleanly with the run.
    for fls_id in (0, 1, 2):
        assert "ready" in (tmp_path / f"fls_{fls_id}.log").read_text()


def test_a_track_whose_relay_moves_away_differs_from_a_still_one(domain, tmp_path):
    # The same check can fail: the relay flies off (0.5 cm/s along x) and takes the
    # target out of its sweet range, so the stream ends where the still run's does not.
    world = TRIO.build()
    config = TrackConfig(sensing_delay=0.1, communication_delay=0.2)
    moving = f"{CIRCLE};1=linear:3,0,0"
    ours = run_track(
        world, parse_motion(moving), 0, 2, config, 3.0, domain_id=domain,
        per_fls=PerFls(TRIO, moving, log_dir=tmp_path),
    )  # fmt: skip
    still = simulate_track(
        world.sensor, world.swarm.points, world.ids, world.swarm.radius,
        parse_motion(CIRCLE), 0, 2, config, 3.0,
    )  # fmt: skip
    core = simulate_track(
        world.sensor, world.swarm.points, world.ids, world.swarm.radius,
        parse_motion(moving), 0, 2, config, 3.0,
    )  # fmt: skip
    assert same_run(ours, core)
    assert not same_run(ours, still)
