"""A swarm of one OS process per FLS (`swazure spawn --per-fls`): the engine's results,
each process's end reported, nothing left running."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from swazure_ros.files.record import RECORD_FILE, read_record

from ..conftest import REPO
from ..waits import PATIENCE, wait_until

GRID = REPO / "config" / "swarms" / "grid25.yaml"
#: The tests' smaller grid (16 FLS processes, not 25), where a test is not of grid25 itself.
GRID16 = Path(__file__).parent / "data" / "grid16.xyz"
GRID16_SWARM = GRID16.with_suffix(".yaml")
BLOCKED = Path(__file__).parent / "data" / "blocked25.xyz"
TRIO = REPO / "config" / "swarms" / "trio.yaml"


def swazure(*args: str, env: dict[str, str] | None = None) -> subprocess.Popen[str]:
    # A process group of its own, as a shell's job: a terminal's Ctrl-C reaches the group.
    return subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=env,
    )


#: What the end of a swarm that stopped cleanly never shows: a process that died or was
#: killed (a watchdog's line, a signal), a crash, a traceback.
UNCLEAN = ("died", "did not end in", "Timeout (", "signal", "Segmentation fault", "Traceback")
#: What the trio's FLS processes leave in their log folder: their logs and their parameters.
WRITTEN = ["fls_0.log", "fls_1.log", "fls_2.log", "parameters.yaml"]


def up(spawn: subprocess.Popen[str]) -> Path:
    """Wait until ``spawn``'s swarm is up and every FLS is on the swarm's radio, as a person
    stopping it would see it; the folder of its FLS processes' logs."""
    line = spawn.stdout.readline()
    assert "swarm up: 3 FLS nodes in 3 processes of one FLS each" in line, (
        line + spawn.stderr.read()
    )
    logs = Path(line.split("(logs in ", 1)[1].split(")", 1)[0])

    def joined() -> bool:
        return all("on the swarm's radio" in last_log(logs, fls_id) for fls_id in range(3))

    assert wait_until(joined, 300), [last_log(logs, fls_id) for fls_id in range(3)]
    return logs


def last_log(logs: Path, fls_id: int) -> str:
    """FLS ``fls_id``'s log so far."""
    return (logs / f"fls_{fls_id}.log").read_text(errors="replace")


def fls_processes(log_dir: Path, launcher: int | None = None) -> list[int]:
    """Process ids of the FLS processes whose parameter file is in ``log_dir``; with
    ``launcher``, only that process's children (what its report of their ends covers)."""
    marker = str(log_dir / "parameters.yaml").encode()
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker in (entry / "cmdline").read_bytes() and (
                    launcher is None or parent(entry) == launcher
                ):
                    found.append(int(entry.name))
            except OSError:
                pass  # ended meanwhile
    return found


def parent(process: Path) -> int:
    """The parent's process id of ``process`` (its folder in /proc)."""
    # The command, in parentheses, may hold spaces: the fields after its last ")".
    return int((process / "stat").read_text().rsplit(")", 1)[1].split()[1])


def test_a_swarm_of_one_process_per_fls_computes_what_the_engine_computes(domain, tmp_path):
    logs = tmp_path / "logs"
    spawn = swazure("spawn", str(GRID), "--per-fls", "--log-dir", str(logs), "--quiet",
                    "--discovery-timeout", "300", "--compute-all",
                    "--out", str(tmp_path / "d"))  # fmt: skip
    out, err = spawn.communicate(timeout=600)
    assert spawn.returncode == 0, err
    assert "25 FLS nodes in 25 processes of one FLS each" in out, out
    assert read_record(tmp_path / "d" / RECORD_FILE).comparison.identical, out
    evaluate = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "evaluate",
         "--cloud", str(GRID.with_suffix(".xyz")), "--scale", "1", "--radius", "0.5",
         "--out", str(tmp_path / "e")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert evaluate.returncode == 0, evaluate.stderr
    distributed = (tmp_path / "d" / "pairs.csv").read_bytes()
    assert distributed == (tmp_path / "e" / "pairs.csv").read_bytes()
    assert distributed.count(b"\n") == 1 + 144  # every blind pair of the grid
    # Each FLS ran alone, said it was ready, and ended cleanly when the swarm did.
    assert "25 FLS processes stopped, every one cleanly (exit code 0)" in err, err
    for fls_id in (0, 12, 24):
        assert "ready" in (logs / f"fls_{fls_id}.log").read_text()
    assert fls_processes(logs) == []


def test_a_swarm_of_one_process_per_fls_solves_its_fit_as_the_engine_does(domain, tmp_path):
    # The grid under the published sensor: two fits (the sweet hops alone, and with the
    # joining decaying hops), each solved by the 16 processes' messages.
    spawn = swazure("spawn", str(GRID16_SWARM), "--per-fls", "--log-dir", str(tmp_path / "logs"),
                    "--quiet", "--discovery-timeout", "300", "--compute-all",
                    "--estimator", "swarm-fit", "--out", str(tmp_path / "d"))  # fmt: skip
    out, err = spawn.communicate(timeout=600)
    assert spawn.returncode == 0, err
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.comparison.identical, out
    assert record.summary.fit.estimator == "swarm-fit"
    assert "16 FLS processes stopped, every one cleanly (exit code 0)" in err, err


def test_each_fls_process_fits_what_it_hears_as_the_engine_does(domain, tmp_path):
    # Each process hears the others' signed measurements over DDS: its own radio's book.
    spawn = swazure("spawn", str(GRID16_SWARM), "--per-fls", "--log-dir", str(tmp_path / "logs"),
                    "--quiet", "--discovery-timeout", "300", "--compute-all",
                    "--estimator", "local-least-squares",
                    "--out", str(tmp_path / "d"))  # fmt: skip
    out, err = spawn.communicate(timeout=600)
    assert spawn.returncode == 0, err
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.comparison.identical, out
    assert record.summary.fit.estimator == "local-least-squares"
    header = (tmp_path / "d" / "pairs.csv").read_text().splitlines()[0]
    assert "covariance_xx" in header and "covariance_zz" in header


def test_move_source_made_by_fls_processes_is_the_engines(domain, tmp_path):
    # Each FLS follows the commanded moves (its own and its neighbours') and measures a
    # path walk in the frame of the world revision the walk names.
    shape = ["--cloud", str(BLOCKED), "--scale", "1", "--radius", "0.5", "--quiet",
             "--discovery-timeout", "300"]  # fmt: skip
    spawn = swazure("spawn", *shape, "--per-fls", "--log-dir", str(tmp_path / "logs"),
                    "--compute-all", "--technique", "move-source",
                    "--out", str(tmp_path / "d"))  # fmt: skip
    out, err = spawn.communicate(timeout=600)
    assert spawn.returncode == 0, err
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.distributed.moves is not None and record.distributed.moves.path_walks == 7
    # The detections carry metres (REP-103), so estimates are the engine's to 1e-9 cm.
    assert record.comparison.identical, out
    assert "25 FLS processes stopped, every one cleanly (exit code 0)" in err, err


def test_ctrl_c_ends_every_process_with_code_0_and_removes_the_temporary_logs_and_key(
    context, tmp_path
):
    from rclpy.node import Node

    from ..ros.helpers import long_lease_environment

    # No --log-dir: the launcher's temporary folder holds the logs and the swarm's key. Its
    # participants are on an hour's lease: a peer that drops a node was told it left.
    environment = long_lease_environment(tmp_path, dict(os.environ))
    spawn = swazure("spawn", str(TRIO), "--per-fls", "--quiet", env=environment)
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)

    def listed() -> set[str]:
        return {name for name, where in probe.get_node_names_and_namespaces() if where == "/swarm"}

    try:
        logs = up(spawn)
        assert wait_until(lambda: {"fls_0", "fls_1", "fls_2", "coordinator"} <= listed(), 300)
        assert (logs / "swarm.key").exists()
        running = fls_processes(logs)
        assert len(running) == 3, running
        os.killpg(spawn.pid, signal.SIGINT)  # a terminal's Ctrl-C: to the launcher's group
        _, err = spawn.communicate(timeout=300)
        # The launcher tells its peers it leaves; the FLSs, stopped with the whole swarm,
        # leave without a word (nobody is left to hear it): only their lease would drop them.
        assert wait_until(lambda: "coordinator" not in listed(), PATIENCE), listed()
        lingering = listed()
    finally:
        if spawn.poll() is None:
            spawn.kill()
        probe.destroy_node()
    assert spawn.returncode == 0, err
    assert "3 FLS processes stopped, every one cleanly (exit code 0)" in err, err
    assert not [word for word in UNCLEAN if word in err], err
    assert [pid for pid in running if Path(f"/proc/{pid}").exists()] == []
    assert lingering == {"fls_0", "fls_1", "fls_2"}
    # Every process ended cleanly: nothing in the folder is wanted any more.
    assert not logs.exists(), sorted(logs.iterdir())


def test_a_swarm_stopped_by_ctrl_c_and_started_again_at_once_computes_the_engines_pairs(
    domain, tmp_path
):
    # The stopped swarm's processes left without telling anyone: the new swarm's
    # participants never hear of them (docs/swarm.md, "Stopping"), and every FLS of the
    # new one takes part to the end, its pairs the engine's (else exit 1).
    first = swazure("spawn", str(TRIO), "--per-fls", "--quiet")
    try:
        up(first)
        os.killpg(first.pid, signal.SIGINT)
        _, err = first.communicate(timeout=300)
    finally:
        if first.poll() is None:
            first.kill()
    assert first.returncode == 0, err
    again = swazure("spawn", str(TRIO), "--per-fls", "--quiet", "--discovery-timeout", "300",
                    "--compute-all", "--out", str(tmp_path / "d"))  # fmt: skip
    try:
        out, err = again.communicate(timeout=600)
    finally:
        if again.poll() is None:
            again.kill()
    assert again.returncode == 0, out + err
    record = read_record(tmp_path / "d" / RECORD_FILE)
    assert record.comparison.identical and not record.distributed.departed, out


def test_an_fls_process_that_died_leaves_its_logs_to_read_and_no_key(domain):
    spawn = swazure("spawn", str(TRIO), "--per-fls", "--quiet")
    logs = None
    try:
        logs = up(spawn)
        # The launcher's own child: only its end is the launcher's to report.
        killed = fls_processes(logs, launcher=spawn.pid)[0]
        os.kill(killed, signal.SIGKILL)
        assert wait_until(lambda: killed not in fls_processes(logs, launcher=spawn.pid), 300)
        assert len(fls_processes(logs, launcher=spawn.pid)) == 2
        os.killpg(spawn.pid, signal.SIGINT)
        _, err = spawn.communicate(timeout=300)
        assert spawn.returncode == 0, err
        # Among the ends: how it ended, and where to read the logs.
        assert "3 FLS processes stopped\n" in err and "process ended with signal 9" in err, err
        assert f"their logs are in {logs}" in err, err
        assert not (logs / "swarm.key").exists()
        assert sorted(path.name for path in logs.iterdir()) == WRITTEN
    finally:
        if spawn.poll() is None:
            spawn.kill()
        if logs is not None:
            shutil.rmtree(logs, ignore_errors=True)


def test_sigterm_stops_every_fls_process_and_leaves_the_logs_but_not_the_key(domain, tmp_path):
    spawn = swazure("spawn", str(TRIO), "--per-fls", "--log-dir", str(tmp_path), "--quiet")
    try:
        up(spawn)
        running = fls_processes(tmp_path)
        assert len(running) == 3, running
        spawn.send_signal(signal.SIGTERM)
        _, err = spawn.communicate(timeout=300)
    finally:
        if spawn.poll() is None:
            spawn.kill()
    assert spawn.returncode == 0, err
    assert "3 FLS processes stopped, every one cleanly (exit code 0)" in err, err
    assert not [word for word in UNCLEAN if word in err], err
    assert [pid for pid in running if Path(f"/proc/{pid}").exists()] == []
    # The user's folder keeps what the FLSs wrote and ran with; the swarm's key ended with it.
    assert sorted(path.name for path in tmp_path.iterdir()) == WRITTEN


def test_a_launcher_killed_outright_leaves_no_fls_process_behind(domain, tmp_path):
    # SIGKILL gives the launcher no time to stop anyone: its FLSs learn of its death from
    # the pipe it alone held open (app.per_fls.FLS_PROGRAM), and end by themselves.
    spawn = swazure("spawn", str(TRIO), "--per-fls", "--log-dir", str(tmp_path), "--quiet")
    try:
        line = spawn.stdout.readline()
        assert "swarm up: 3 FLS nodes in 3 processes" in line, line + spawn.stderr.read()
        running = fls_processes(tmp_path)
        assert len(running) == 3, running
        spawn.kill()
        spawn.communicate(timeout=PATIENCE)
        deadline = time.monotonic() + PATIENCE
        while fls_processes(tmp_path) and time.monotonic() < deadline:
            time.sleep(0.2)
    finally:
        if spawn.poll() is None:
            spawn.kill()
    assert fls_processes(tmp_path) == []
    for fls_id in range(3):
        assert "Traceback" not in (tmp_path / f"fls_{fls_id}.log").read_text()


def test_an_fls_process_that_fails_is_named_in_one_line(domain, tmp_path):
    # FLS 1 is told to aim its camera at itself: its program refuses to start.
    swarm = tmp_path / "trio.yaml"
    swarm.write_text(
        TRIO.read_text().replace("../track/trio.xyz", str(REPO / "config/track/trio.xyz"))
        + "  fls:\n    1:\n      camera_view: 1\n"
    )
    spawn = swazure("spawn", str(swarm), "--per-fls", "--log-dir", str(tmp_path / "logs"),
                    "--quiet")  # fmt: skip
    try:
        _, err = spawn.communicate(timeout=PATIENCE)
    finally:
        if spawn.poll() is None:
            spawn.kill()
    assert spawn.returncode != 0
    lines = err.strip().splitlines()
    failure = [line for line in lines if line.startswith("swazure spawn: error:")]
    assert len(failure) == 1, err
    assert "FLS 1's process ended with code 2" in failure[0], failure
    assert "camera_view names this FLS itself" in failure[0], failure
    assert "Traceback" not in err, err
    # The other two were stopped.
    assert fls_processes(tmp_path / "logs") == []
    assert os.path.exists(tmp_path / "logs" / "fls_1.log")


def test_an_fls_process_killed_mid_run_departs_and_the_living_get_the_engines_pairs(
    domain, tmp_path
):
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.core.neighbourhood import without
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE)
    lost = []
    with RunningSwarm.start(config, on_lost=lost.append) as swarm:
        # FLS 10 relays many paths (1 10 4 among them): killed (no goodbye) as the run starts.
        swarm.processes.fls.processes[10].kill()
        result = swarm.discover(policy, timeout=PATIENCE)
        assert result.outcome.departed == frozenset({10})
        assert [(one.fls_id, one.code) for one in lost] == [(10, -9)]
        world = swarm.world
        expected = evaluate_pairs(without(world.hood, np.array([10])), policy)
        found = {
            (s, one.target): one for s, some in result.outcome.estimates.items() for one in some
        }
        keep = (expected.source != 10) & (expected.target != 10)
        assert len(found) == int(keep.sum())
        for pair in np.flatnonzero(keep).tolist():
            one = found[(int(expected.source[pair]), int(expected.target[pair]))]
            assert (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
            assert one.path == tuple(expected.path(pair))
        # It mattered: the whole grid's paths go through it (ids are the grid's rows).
        whole = evaluate_pairs(world.hood, policy)
        assert any(10 in whole.path(pair) for pair in range(len(whole)))
        # The next run needs no restart: no round waits for the dead FLS's radio.
        again = swarm.discover(policy, timeout=PATIENCE)
        assert again.outcome.restarts == 0 and again.outcome.departed == frozenset({10})


#: Seconds an FLS process is stopped at least: longer than a round's timeout, shorter than
#: a DDS lease (stopped past it, it comes back otherwise: the test of STOPPED_PAST_LEASE).
#: It stays stopped until the coordinator has counted it departed, however long a loaded
#: machine takes to get there: resumed by the clock alone, it once spoke again before.
STOPPED_FOR = 8.0


def test_an_fls_process_stopped_for_a_while_departs_and_is_taken_back_when_it_speaks_again(
    domain, tmp_path
):
    """kill -STOP, kill -CONT: the FLS departs from the run it missed, and comes back.

    It comes back by its own signed messages (its radio's acks, signed after it
    was known departed) or by the graph showing it again; its pairs are then
    the engine's once more.
    """
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE)
    with RunningSwarm.start(config) as swarm:
        swarm.coordinator.round_timeout = 3.0  # silent for 3 s: departed
        pid = swarm.processes.fls.processes[10].pid
        os.kill(pid, signal.SIGSTOP)
        stopped, resumed = time.monotonic(), []

        def resume_after_a_while() -> None:
            departed = 10 in swarm.coordinator.departed_so_far()
            if not resumed and departed and time.monotonic() > stopped + STOPPED_FOR:
                os.kill(pid, signal.SIGCONT)
                resumed.append(time.monotonic())

        try:
            missed = swarm.run(
                swarm.coordinator.discover(policy), timeout=PATIENCE, step=resume_after_a_while
            )
        finally:
            if not resumed:
                os.kill(pid, signal.SIGCONT)
                resumed.append(time.monotonic())
        resumed = resumed[0]
        assert 10 in missed.outcome.departed
        runs = runs_until_every_fls_is_back(swarm, policy, timeout=PATIENCE)
        recovered = time.monotonic()
        print(
            f"stopped {STOPPED_FOR:g} s, departed by a run of {missed.seconds:.1f} s; back "
            f"and every pair the engine's {recovered - resumed:.1f} s after it resumed, "
            f"in {len(runs)} runs"
        )
        assert runs[-1].outcome.departed == frozenset(), [run.outcome.departed for run in runs]
        assert_every_pair_is_the_engines(swarm.world, runs[-1], policy)
        # Queries to it are answered again.
        assert 10 not in swarm.coordinator.departed_so_far()


def test_forged_detections_of_an_fls_change_no_answer_and_are_counted_on_its_topic(
    domain, tmp_path
):
    """A peer publishes FLS 10's camera readings: none (its paths would detour), and readings
    signed with another key. FLS 10's guard drops both; 1 -> 4 still goes 1 10 4."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from swazure_interfaces.msg import Detections

    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.ros.plumbing.names import DETECTIONS_QOS, DETECTIONS_TOPIC
    from swazure_ros.ros.security.auth import SwarmKey, new_key
    from swazure_ros.sim.world import WorldSpec

    from ..ros.conftest import make_context

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE)
    with RunningSwarm.start(config) as swarm:
        context = make_context(domain)
        node = Node("forger", namespace="swarm", context=context)
        counts: dict[str, int] = {}

        def on_diagnostics(array: DiagnosticArray) -> None:
            for status in array.status:
                if status.hardware_id == "/swarm/fls_10":
                    counts.update({one.key: int(one.value) for one in status.values})

        node.create_subscription(DiagnosticArray, "/diagnostics", on_diagnostics, 10)
        forged = node.create_publisher(Detections, f"fls_10/{DETECTIONS_TOPIC}", DETECTIONS_QOS)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        keys = [SwarmKey(), SwarmKey(new_key())]

        def forge() -> None:
            for key in keys:
                message = Detections(revision=swarm.world.revision)
                message.header.frame_id = "fls_10"
                forged.publish(key.serialize(message))
            executor.spin_once(timeout_sec=0.01)

        def refused() -> int:
            return sum(
                value
                for name, value in counts.items()
                if name.startswith(f"dropped ~/{DETECTIONS_TOPIC}: not signed")
            )

        try:
            wait_until(
                lambda: forged.get_subscription_count() >= 1, PATIENCE, lambda: swarm.spin(0.05)
            )
            result = swarm.run(swarm.coordinator.discover(policy, [1], [4]), PATIENCE, step=forge)
            wait_until(lambda: refused() >= 2, PATIENCE, lambda: (swarm.spin(0.1), forge()))
        finally:
            executor.shutdown()
            node.destroy_node()
            context.try_shutdown()
        assert refused() >= 2, counts
        expected = evaluate_pairs(swarm.world.hood, policy)
        row = int(np.flatnonzero((expected.source == 1) & (expected.target == 4))[0])
        (answer,) = result.outcome.estimates[1]
        assert answer.path == tuple(expected.path(row)) == (1, 10, 4)


def false_offer_forger(domain: int, world):
    """A peer that offers, for every FLS of a swarm without a key, a label no FLS takes.

    At each round it sends, for the round after it, each FLS's forged offer twice
    on that FLS's radio cell (a label from another FLS over one hop of 7 cm, the
    vector [123, 456, 789]): so the forgeries are always first, and fill a
    sender's slots before its real offer comes. A context manager, as
    test/ros/test_hostile_peers.py's Forger, whose node and counts it keeps.
    """
    from swazure_interfaces.msg import DiscoveryControl, PathOffer

    from swazure_ros.protocol.cells import BANDS, band_of, radio_cells
    from swazure_ros.ros.plumbing.names import ROUND_QOS, radio_topic
    from swazure_ros.ros.security.auth import SwarmKey

    from ..ros.test_hostile_peers import Forger

    class FalseOfferForger(Forger):
        def __init__(self) -> None:
            self.ids = [int(fls_id) for fls_id in world.ids]
            super().__init__(domain, world, self.ids[0], self.ids[1], SwarmKey())
            grids = radio_cells(world.sensor, world.swarm.radius)
            where = np.array([world.position(fls_id) for fls_id in self.ids])
            self.cells = {}  # (band, FLS) -> its cell's publisher
            by_topic = {}
            for band in BANDS:
                for fls_id, cell in zip(self.ids, grids[band].of(where).tolist(), strict=True):
                    topic = radio_topic(band, cell)
                    if topic not in by_topic:
                        by_topic[topic] = self.node.create_publisher(PathOffer, topic, ROUND_QOS)
                    self.cells[(band, fls_id)] = by_topic[topic]
            self.publishers = list(by_topic.values())

        def _on_control(self, control: DiscoveryControl) -> None:
            if control.command != DiscoveryControl.COMMAND_ROUND:
                return
            band = band_of(control.phase)
            for index, fls_id in enumerate(self.ids):
                other = self.ids[(index + 7) % len(self.ids)]
                forged = PathOffer(
                    run_id=control.run_id, phase=control.phase, round=control.round + 1,
                    sender_id=fls_id, source_ids=[other], hops=[1], lengths=[7.0],
                    errors=[0.1], vectors=[123.0, 456.0, 789.0], path_offsets=[0, 2],
                    path_ids=[other, fls_id],
                )  # fmt: skip
                for _ in range(2):
                    self.cells[(band, fls_id)].publish(forged)
                    self.sent += 1

        def dropped_as_implausible(self) -> int:
            """Offers the swarm's FLS processes reported dropped as implausible, summed."""
            return sum(
                int(value)
                for where, counts in dict(self.diagnostics).items()
                if where.startswith("/swarm/fls_")
                for key, value in counts.items()
                if key.startswith("dropped radio: implausible:")
            )

    return FalseOfferForger()


def test_offers_every_fls_drops_as_implausible_change_no_pair_of_a_swarm_without_a_key(
    domain, tmp_path
):
    """Per-FLS grid16 under --no-key: each FLS's offer forged, false, first, twice a round.

    Before, a process counted a forged offer for its sender and acknowledged the
    round without the real one, or kept the forgeries and ignored the real one:
    1 -> 4 went from SWEET over 1 10 4 to a longer path, DECAYING or NO_PATH."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.core.evaluate import evaluate_pairs
    from swazure_ros.core.evaluation import SWEET_PATH
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE,
                         authenticate=False)  # fmt: skip
    with RunningSwarm.start(config) as swarm:
        with false_offer_forger(domain, swarm.world) as forger:
            wait_until(
                lambda: (
                    all(one.get_subscription_count() >= 1 for one in forger.publishers)
                    and forger.controls.get_publisher_count() >= 1
                ),
                PATIENCE,
                lambda: swarm.spin(0.05),
            )
            result = swarm.run(swarm.coordinator.discover(policy), timeout=PATIENCE)
            wait_until(
                lambda: forger.dropped_as_implausible() >= 1, PATIENCE, lambda: swarm.spin(0.05)
            )
        assert forger.sent >= 2 * 16 and forger.dropped_as_implausible() >= 1, forger.diagnostics
        expected = evaluate_pairs(swarm.world.hood, policy)
        found = {
            (s, one.target): one for s, some in result.outcome.estimates.items() for one in some
        }
        assert len(found) == len(expected) == 84
        for pair in range(len(expected)):
            one = found[(int(expected.source[pair]), int(expected.target[pair]))]
            assert (one.status, one.path) == (expected.status[pair], tuple(expected.path(pair)))
        assert (found[(1, 4)].status, found[(1, 4)].path) == (SWEET_PATH, (1, 10, 4))


def assert_every_pair_is_the_engines(world, result, policy: str) -> None:
    """Every blind pair of the whole swarm in ``result``, path and status the engine's."""
    from swazure_ros.core.evaluate import evaluate_pairs

    expected = evaluate_pairs(world.hood, policy)
    found = {(s, one.target): one for s, some in result.outcome.estimates.items() for one in some}
    assert len(found) == len(expected)
    for pair in range(len(expected)):
        one = found[(int(expected.source[pair]), int(expected.target[pair]))]
        assert (one.status, one.reason) == (expected.status[pair], expected.reason[pair])
        assert one.path == tuple(expected.path(pair))


def runs_until_every_fls_is_back(swarm, policy: str, timeout: float) -> list:
    """Discovery runs, one after the other, until one has no FLS departed (or ``timeout`` s)."""
    deadline = time.monotonic() + timeout
    runs = []
    while not runs or (runs[-1].outcome.departed and time.monotonic() < deadline):
        swarm.spin(1.0)
        runs.append(swarm.discover(policy, timeout=PATIENCE))
    return runs


#: Fast DDS's settings with a 5 s lease, for every participant of a swarm whose test
#: stops an FLS past it (one lease for all: ../shared/notes/liveness-and-apis.md).
SHORT_LEASE = REPO / "config" / "fastdds.xml"
#: Seconds an FLS process is stopped at least: more than twice SHORT_LEASE's lease.
STOPPED_PAST_LEASE = 12.0


def test_an_fls_process_stopped_past_its_lease_starts_afresh_and_is_taken_back(
    domain, tmp_path, monkeypatch
):
    """kill -STOP past the lease: every peer drops the FLS's participant; kill -CONT: the
    process finds it stood still that long, starts afresh in place (a new participant, the
    same pid), and is taken back."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    monkeypatch.setenv("FASTRTPS_DEFAULT_PROFILES_FILE", str(SHORT_LEASE))
    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE)
    with RunningSwarm.start(config) as swarm:
        coordinator = swarm.coordinator
        pid = swarm.processes.fls.processes[10].pid
        os.kill(pid, signal.SIGSTOP)
        stopped = time.monotonic()
        try:
            # Its lease runs out: the graph shows it gone (a peer dropped its participant).
            gone = wait_until(
                lambda: 10 in coordinator.membership.gone, PATIENCE, lambda: swarm.spin(0.2)
            )
            wait_until(
                lambda: time.monotonic() > stopped + STOPPED_PAST_LEASE,
                30,
                lambda: swarm.spin(0.2),
            )
        finally:
            os.kill(pid, signal.SIGCONT)
        resumed = time.monotonic()
        assert gone, "FLS 10's lease never ran out"
        runs = runs_until_every_fls_is_back(swarm, policy, timeout=PATIENCE)
        print(
            f"stopped {resumed - stopped:.1f} s; back and every pair the engine's "
            f"{time.monotonic() - resumed:.1f} s after it went on, in {len(runs)} runs"
        )
        assert runs[-1].outcome.departed == frozenset(), [run.outcome.departed for run in runs]
        assert_every_pair_is_the_engines(swarm.world, runs[-1], policy)
        process = swarm.processes.fls.processes[10]
        assert process.pid == pid and process.poll() is None
        assert "starting afresh (1 so far)" in (tmp_path / "fls_10.log").read_text()


def test_a_killed_fls_process_started_again_with_its_id_rejoins_with_the_engines_pairs(
    domain, tmp_path
):
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=PATIENCE)
    with RunningSwarm.start(config) as swarm:
        first = swarm.processes.fls.processes[10]
        first.kill()
        assert wait_until(
            lambda: 10 in swarm.coordinator.membership.gone, PATIENCE, lambda: swarm.spin(0.2)
        )
        without = swarm.discover(policy, timeout=PATIENCE)
        assert without.outcome.departed == frozenset({10})
        # Started again as a person would: the same id and arguments, a new process.
        swarm.processes.restart(10)
        again = swarm.processes.fls.processes[10]
        assert again.pid != first.pid and again.poll() is None
        started = time.monotonic()
        runs = runs_until_every_fls_is_back(swarm, policy, timeout=PATIENCE)
        print(
            f"started again; back and every pair the engine's {time.monotonic() - started:.1f} s "
            f"later, in {len(runs)} runs"
        )
        assert runs[-1].outcome.departed == frozenset(), [run.outcome.departed for run in runs]
        assert_every_pair_is_the_engines(swarm.world, runs[-1], policy)
        assert (tmp_path / "fls_10.log").read_text().count("ready, ") == 2  # both lives


#: Busy loops beside the swarm: with the test run's own, a load of 6 or more on 2 cores.
BUSY_LOOPS = 4


def test_a_swarm_of_one_process_per_fls_beside_busy_loops_loses_no_fls(domain, tmp_path):
    """Slow is not dead: 16 FLS processes (at nice 10) beside busy loops come up, discover
    every blind pair with none departed, and find the engine's pairs."""
    from swazure_ros.app.config import SwarmConfig
    from swazure_ros.app.swarm import RunningSwarm
    from swazure_ros.sim.world import WorldSpec

    policy = "shortest-length"
    spec = WorldSpec(cloud=str(GRID16), scale=1.0, radius=0.5)
    config = SwarmConfig(spec, per_fls=True, log_dir=str(tmp_path), discovery_timeout=300)
    busy = [
        subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(BUSY_LOOPS)
    ]
    try:
        with RunningSwarm.start(config) as swarm:
            bring_up = swarm.bring_up
            result = swarm.discover(policy, timeout=300)
            load = os.getloadavg()[0]
    finally:
        for loop in busy:
            loop.kill()
            loop.wait()
    print(
        f"up in {bring_up.seconds:.1f} s, discovery {result.seconds:.1f} s, "
        f"{result.outcome.rounds} rounds, {result.outcome.restarts} restarts, load {load:.1f}"
    )
    assert result.outcome.departed == frozenset(), result.outcome.warnings
    assert_every_pair_is_the_engines(swarm.world, result, policy)
