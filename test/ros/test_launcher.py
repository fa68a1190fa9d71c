"""A swarm split over processes, `swazure spawn`, `swazure echo` and the real `ros2` CLI."""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from geometry_msgs.msg import Vector3
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from swazure_interfaces.msg import Measurements, MoveCommand, MoveCommands
from swazure_interfaces.srv import GetNeighbours

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.cli.main import build_parser
from swazure_ros.cli.spawn import config_from_args
from swazure_ros.cli.swarm_file import apply_swarm_file
from swazure_ros.files.reading import config_dir
from swazure_ros.files.record import RECORD_FILE, read_record
from swazure_ros.ros.clients.query import SwarmQueries
from swazure_ros.ros.security.keys import new_key
from swazure_ros.sim.world import WorldSpec

from ..conftest import SHARED, running, still_running
from ..waits import PATIENCE, wait_until
from .helpers import (
    ECHO_LATCHED,
    LATCHED,
    ROS2_CALL_TIMEOUT,
    ask_ros2,
    assert_matches,
    echo_first,
    engine_expectations,
    long_lease_environment,
    matches,
    run_ros2,
)

WORLD = WorldSpec("helix:100", beta=0.5)
ROS2 = Path(sys.executable).parent / "ros2"


@pytest.fixture
def fast_params(tmp_path):
    path = tmp_path / "swarm.yaml"
    path.write_text("/**:\n  ros__parameters:\n    publish_period: 0.2\n")
    return path


def swazure(*args, **options):
    return subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **options,
    )


def stop(process, timeout=PATIENCE):
    """SIGTERM, then wait; the launcher must exit 0 having stopped every node."""
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=timeout)
    return process.returncode, out, err


def test_swarm_split_over_two_processes_gives_the_same_measurements(context, domain, fast_params):
    config = SwarmConfig(WORLD, processes=2, domain_id=domain, params_file=str(fast_params))
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    latest = {}
    probe.create_subscription(
        Measurements, "/swarm/measurements", lambda m: latest.__setitem__(m.source_id, m), LATCHED
    )
    try:
        with RunningSwarm.start(config) as swarm:
            bring_up = swarm.bring_up
            assert bring_up.processes == 2 and len(bring_up.peak_rss_mb) == 2
            world = swarm.world

            def spin_both():
                swarm.spin(0.02)
                for _ in range(500):  # one callback per spin_once: drain the backlog
                    executor.spin_once(timeout_sec=0.0)

            def until(condition):
                return wait_until(condition, PATIENCE, spin_both)

            assert until(lambda: len(latest) == len(world.ids)), (len(latest), len(world.ids))
            expected, _ = engine_expectations(world)
            for fls_id, message in latest.items():
                assert_matches(message, expected[fls_id])

            # A move made by the world node in the first process reaches the second.
            remote = max(
                (i for i in expected if i not in swarm.host.fls_ids),
                key=lambda i: len(expected[i]),
            )
            neighbour = int(next(iter(expected[remote])))
            shift = np.array([0.3, 0.0, 0.0])
            moved = world.moved({neighbour: world.position(neighbour) + shift})
            moved_expected, _ = engine_expectations(moved)
            command = MoveCommand(fls_id=neighbour, kind=MoveCommand.KIND_STEP_ASIDE)
            command.displacement = Vector3(x=shift[0], y=shift[1], z=shift[2])
            publisher = probe.create_publisher(MoveCommands, "/swarm/move_commands", 10)
            assert until(lambda: publisher.get_subscription_count() > 0)
            # The swarm takes only what its key signs (docs/security.md).
            publisher.publish(swarm.key.serialize(MoveCommands(commands=[command])))

            def remote_sees_move():
                message = latest.get(remote)
                return message is not None and matches(message, moved_expected[remote])

            assert until(remote_sees_move)
    finally:
        executor.shutdown()
        probe.destroy_node()


def test_a_display_s_launcher_holds_its_own_flss_pairs_and_its_hosts_answer_as_the_flss_would(
    domain, fast_params
):
    spec = WorldSpec("helix:40", beta=0.5)
    config = SwarmConfig(
        spec,
        processes=2,
        domain_id=domain,
        params_file=str(fast_params),
        neighbour_services="hosts",
        whole_world=False,
    )
    with RunningSwarm.start(config) as swarm:
        node = swarm.host.host_node
        world = spec.build()  # the whole, for the expected answers
        # The launcher's world: the pairs of its own FLSs, every one of them.
        own = np.isin(world.ids[world.hood.pairs.first], swarm.host.fls_ids) | np.isin(
            world.ids[world.hood.pairs.second], swarm.host.fls_ids
        )
        held = swarm.world.hood.pairs
        assert 0 < len(held.first) == int(own.sum()) < len(world.hood.pairs.first)
        remote = next(int(i) for i in world.ids if int(i) not in swarm.host.fls_ids)
        hosts = {"/swarm/host_0/get_neighbours", "/swarm/host_1/get_neighbours"}

        def services():
            return {name for name, _ in node.get_service_names_and_types()}

        assert wait_until(lambda: hosts <= services(), PATIENCE, lambda: swarm.spin(0.05))
        assert not [name for name in services() if re.fullmatch(r"/swarm/fls_\d+/.*", name)]
        _, expected = engine_expectations(world)
        with SwarmQueries("swarm", domain, step=lambda: swarm.spin(0.01)) as queries:
            # host_0 is asked first: it answers for its own FLSs, and says it does not host
            # the others, whom host_1 answers for.
            sample = world.ids[1::4].tolist()  # none a process's first FLS
            assert {fls_id in swarm.host.fls_ids for fls_id in sample} == {True, False}
            for fls_id in sample:
                known, sets = queries.neighbours(fls_id, PATIENCE), expected[fls_id]
                assert known.blind == tuple(sorted(sets["blind"]))
                assert known.sweet == tuple(sorted(sets["sweet"]))
                assert known.visible_sweet == tuple(sorted(sets["visible_sweet"]))
                assert known.decaying == tuple(sorted(sets["decaying"]))
            client = queries.node.create_client(GetNeighbours, "/swarm/host_0/get_neighbours")

            def spin_both():
                queries.executor.spin_once(timeout_sec=0.01)
                swarm.spin(0.01)

            for asked, words in ((remote, f"does not host FLS {remote}"), (-1, "name one")):
                future = client.call_async(GetNeighbours.Request(fls_id=asked))
                assert wait_until(future.done, PATIENCE, spin_both)
                assert not future.result().success and words in future.result().message


def test_spawn_until_ready_prints_bring_up_writes_its_record_and_exits_0(domain, tmp_path):
    run = swazure(
        "spawn", "--cloud", "helix:60", "--beta", "0.5", "--until-ready", "--quiet",
        "--out", str(tmp_path),
    )  # fmt: skip
    out, err = run.communicate(timeout=PATIENCE)
    assert run.returncode == 0, err
    assert "swarm up: 60 FLS nodes in 1 process(es)" in out
    assert "peak memory" in out
    # What a script reads of a served swarm: its bring-up, as data.
    record = read_record(tmp_path / RECORD_FILE)
    assert record.command == "spawn" and record.summary is None
    assert record.bring_up.flss == 60 and record.bring_up.processes == 1
    assert record.bring_up.seconds > 0 and len(record.bring_up.peak_rss_mb) == 1


def test_a_swarm_from_a_swarm_file_gives_every_fls_and_one_fls_their_parameters(domain):
    swarm_file = config_dir() / "swarms" / "torus.yaml"
    argv = ["spawn", str(swarm_file), "--domain-id", str(domain), "--processes", "2"]
    config = config_from_args(apply_swarm_file(build_parser().parse_args(argv)))
    assert config.processes == 2 and config.world.cloud == "torus:120"
    with RunningSwarm.start(config) as swarm:
        nodes = swarm.host.fls_by_id
        # Shares are regions of the shape (a k-d split): FLS 0 lies in the second one.
        assert 0 not in nodes and len(nodes) == 60
        other = nodes[max(nodes)]
        assert other.get_parameter("publish_period").value == 0.5  # every FLS's, from the file
        assert other.tracking.service is False  # config/swarm.yaml's
        services = dict(swarm.host.host_node.get_service_names_and_types())
        # FLS 0 took its own parameters in the other process: it offers tracking.
        assert "/swarm/fls_0/track" in services
        assert f"/swarm/fls_{max(nodes)}/track" not in services


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cloud", "no-such-shape", "--beta", "0.5"], "unknown shape"),
        (["--cloud", "helix:60"], "give --beta"),
        (["--cloud", "helix:60", "--beta", "0.5", "--processes", "0"], "--processes"),
        (["--cloud", "helix:60", "--beta", "0.5", "--params", "/no/such.yaml"], "no such file"),
    ],
)
def test_spawn_bad_input_gives_one_line_and_exit_2(domain, args, message):
    run = swazure("spawn", *args, "--until-ready", "--quiet")
    _, err = run.communicate(timeout=PATIENCE)
    assert run.returncode == 2, err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err


def test_spawn_with_a_key_file_others_can_read_warns_in_one_line_and_comes_up(domain, tmp_path):
    # Issue 66: taken without a word before; legal but unwise, so taken with one.
    key = tmp_path / "swarm.key"
    key.write_text(new_key().hex() + "\n")
    key.chmod(0o644)
    run = swazure("spawn", "--cloud", "helix:20", "--beta", "0.5", "--key-file", str(key),
                  "--until-ready", "--quiet")  # fmt: skip
    out, err = run.communicate(timeout=300)
    assert run.returncode == 0, err
    assert out.startswith("swarm up"), out
    warned = [line for line in err.splitlines() if "open to others than its owner" in line]
    assert warned == [
        f"warning: swarm key file {key} is open to others than its owner (mode 0644): whoever "
        f"reads it can sign as the swarm; taken anyway (chmod 600 {key})"
    ], err


def test_spawn_and_evaluate_refuse_a_sensor_without_a_blind_range_in_the_same_line(
    domain, tmp_path
):
    # Issue 66: evaluate took sweet_min 0, which spawn refused only with --compute-all.
    sensor = tmp_path / "no-blind.yaml"
    default = (config_dir() / "sensor.yaml").read_text()
    sensor.write_text(default.replace("sweet_min: 6.0", "sweet_min: 0"))
    said = []
    for verb, more in (("spawn", ["--until-ready", "--quiet"]), ("evaluate", [])):
        run = swazure(verb, "--cloud", "helix:60", "--beta", "0.5", "--sensor", str(sensor), *more)
        _, err = run.communicate(timeout=PATIENCE)
        assert run.returncode == 2, err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
        said.append(err.removeprefix(f"swazure {verb}: error: "))
    assert said[0] == said[1], said
    assert "sweet_min must be above 0 (the blind range is 0 < t < sweet_min), got 0" in said[0]


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("/**:\n  ros__parameters:\n    publish_period: -2.0\n", "publish_period must be"),
        (
            "/**:\n  ros__parameters:\n    republish_period: -1.0\n",
            "republish_period must be 0 or a positive number",
        ),
        ("/**:\n  ros__parameters:\n    publish_period: [1, 2\n", "parameter file"),
    ],
)
def test_spawn_with_invalid_parameters_refuses_to_start(domain, tmp_path, content, message):
    params = tmp_path / "bad.yaml"
    params.write_text(content)
    run = swazure("spawn", "--cloud", "helix:60", "--beta", "0.5", "--params", str(params))
    _, err = run.communicate(timeout=PATIENCE)
    assert run.returncode == 2, err
    assert message in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.parametrize("value", ["0.0", "-1.0", ".nan", ".inf"])
def test_spawn_refuses_a_round_timeout_that_is_not_a_positive_number_of_seconds(
    domain, tmp_path, value
):
    # Issue 66: a round timeout of 0 s, below, or not finite, as a ROS parameter.
    params = tmp_path / "bad.yaml"
    params.write_text(f"/**/coordinator:\n  ros__parameters:\n    round_timeout: {value}\n")
    run = swazure("spawn", "--cloud", "helix:60", "--beta", "0.5", "--params", str(params),
                  "--quiet")  # fmt: skip
    _, err = run.communicate(timeout=PATIENCE)
    assert run.returncode == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(
        "swazure spawn: error: /swarm/coordinator: parameter round_timeout must be a positive "
        "number of seconds below 86400, got "
    ), err


@pytest.fixture
def running_swarm(domain, fast_params):
    """`swazure spawn` in its own process, serving until stopped."""
    process = swazure(
        "spawn", "--cloud", "helix:100", "--beta", "0.5", "--params", str(fast_params), "--quiet"
    )
    try:
        line = process.stdout.readline()
        assert line.startswith("swarm up"), line + process.stderr.read()
        yield process
    finally:
        if process.poll() is None:
            code, _, err = stop(process)
            assert code == 0, err


def test_swazure_echo_shows_a_measurement_of_a_running_swarm(running_swarm):
    # Every FLS of the helix sends once when a reader comes; one at an end may see nobody.
    echo = swazure("echo", "/swarm/measurements", "--count", "100", "--timeout", str(PATIENCE))
    out, err = echo.communicate(timeout=PATIENCE + 60)
    assert echo.returncode == 0, err
    assert out.endswith("---\n") and out.count("---\n") == 100
    assert "source_id:" in out and "poses:" in out and "tracking_distance:" in out
    # Every FLS's latched message, once: a late reader is sent all of them at once.
    sources = {line.split(":")[1] for line in out.splitlines() if line.startswith("source_id:")}
    assert len(sources) == 100, sorted(sources)
    code, _, err = stop(running_swarm)
    assert code == 0, err
    # A stop is not a failure: no callback reports an exception on the way out. A process
    # whose executor a busy machine held back says so, and that is no failure either.
    said = [line for line in err.strip().splitlines() if not line.endswith("announced it again")]
    assert said == ["stopping the swarm"], err


@pytest.fixture
def ros2_cli():
    """Skip, before any swarm starts, where the real ros2 CLI is absent."""
    if not SHARED.is_dir():
        pytest.skip("the ros2 CLI wheels live in ../shared, which is not beside the repo")
    if not ROS2.exists():
        pytest.skip(f"{ROS2} is not installed (make setup installs it from ../shared)")


def ros2_environment():
    """This test's environment, with the venv as the ament prefix the ros2 CLI looks in."""
    return dict(os.environ, AMENT_PREFIX_PATH=str(Path(sys.executable).parents[1]))


def ros2(*args, timeout=ROS2_CALL_TIMEOUT):
    return run_ros2([str(ROS2), *args], ros2_environment(), timeout)


def test_real_ros2_cli_sees_nodes_topic_and_service(ros2_cli, running_swarm):
    assert shutil.which(str(ROS2))
    for _ in range(3):  # without a daemon, discovery gets only --spin-time
        nodes = ros2("node", "list", "--no-daemon", "--spin-time", "3")
        if "/swarm/fls_0" in nodes.stdout.split():
            break
    assert "/swarm/fls_0" in nodes.stdout.split(), nodes.stdout + nodes.stderr
    # The latched messages arrive in any order, and an FLS at the helix's end may see nobody.
    echoed = echo_first(
        [
            str(ROS2),
            "topic",
            "echo",
            *ECHO_LATCHED,
            "--once",
            "--filter",
            "len(m.poses) > 0",
            "/swarm/measurements",
            "swazure_interfaces/msg/Measurements",
        ],
        ros2_environment(),
    )
    assert "source_id:" in echoed and "vector:" in echoed, echoed
    # In metres (REP-103), in the measuring FLS's frame: the helix's neighbours are
    # centimetres apart, so every tracking distance is a small fraction of a metre.
    distances = [
        float(line.split(":")[1]) for line in echoed.splitlines() if "tracking_distance:" in line
    ]
    assert distances and all(0 < distance < 0.5 for distance in distances), echoed
    source = next(line for line in echoed.splitlines() if line.startswith("source_id:"))
    assert f"frame_id: fls_{source.split(':')[1].strip()}" in echoed, echoed
    asked = ("service", "call", "/swarm/fls_0/get_neighbours",
             "swazure_interfaces/srv/GetNeighbours", "{fls_id: 0}")  # fmt: skip
    call = ask_ros2(lambda timeout: ros2(*asked, timeout=timeout))
    assert call.returncode == 0, call.stderr
    assert "success=True" in call.stdout
    # Its process's host node answers for it too, with the same response.
    hosted_asked = ("service", "call", "/swarm/host_0/get_neighbours",
                    "swazure_interfaces/srv/GetNeighbours", "{fls_id: 0}")  # fmt: skip
    hosted = ask_ros2(lambda timeout: ros2(*hosted_asked, timeout=timeout))
    assert hosted.returncode == 0, hosted.stderr
    assert response_line(hosted.stdout) == response_line(call.stdout), hosted.stdout


def response_line(output):
    """The response a `ros2 service call` prints, as one line."""
    return next(line for line in output.splitlines() if "Response(" in line)


def test_real_ros2_service_call_computes_a_pose_and_echo_shows_the_estimates(
    ros2_cli, running_swarm
):
    from swazure_ros.core.evaluate import evaluate_pairs

    world = WORLD.build()
    engine = evaluate_pairs(world.hood, "shortest-length")
    pair = int(np.flatnonzero(engine.hops >= 2)[0])
    source, target = int(world.ids[engine.source[pair]]), int(world.ids[engine.target[pair]])
    # Each call's run publishes its estimates once, and the echo may not be matched
    # yet: call again until the echo has printed one.
    path = ", ".join(str(int(world.ids[k])) for k in engine.path(pair))

    def call() -> None:
        asked = ("service", "call", "/swarm/coordinator/compute_pose",
                 "swazure_interfaces/srv/ComputePose",
                 f"{{source_id: {source}, target_id: {target}, policy: 1}}")  # fmt: skip
        answer = ask_ros2(lambda timeout: ros2(*asked, timeout=timeout))
        assert answer.returncode == 0, answer.stderr
        assert "success=True" in answer.stdout, answer.stdout
        assert (
            f"path=[{path}]" in answer.stdout or f"path=array('I', [{path}])" in answer.stdout
        ), answer.stdout

    echoed = echo_first(
        [str(ROS2), "topic", "echo", "--once", "/swarm/estimates",
         "swazure_interfaces/msg/PoseEstimates"],
        ros2_environment(),
        step=call,
    )  # fmt: skip
    assert f"source_id: {source}" in echoed and f"target_ids:\n- {target}\n" in echoed, echoed


def further_processes(launcher: int) -> list[int]:
    """Process ids of the running further processes of swarm launcher ``launcher``: its
    children that multiprocessing started to host a share."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and running(int(entry.name)):
            try:
                status = dict(
                    line.split(":", 1) for line in (entry / "status").read_text().splitlines()
                )
                if (
                    int(status["PPid"]) == launcher
                    and b"spawn_main" in (entry / "cmdline").read_bytes()
                ):
                    found.append(int(entry.name))
            except (OSError, KeyError, ValueError):
                pass  # ended meanwhile
    return found


def test_a_launcher_killed_outright_leaves_no_further_process_behind(domain, fast_params):
    # SIGKILL (or the kernel's out-of-memory killer) gives the launcher no time to stop its
    # further processes: each learns of its death from multiprocessing's sentinel and ends.
    spawn = swazure(
        "spawn", "--cloud", "helix:100", "--beta", "0.5", "--processes", "2",
        "--params", str(fast_params), "--quiet",
    )  # fmt: skip
    further: list[int] = []
    held = -1  # a pidfd of the further process: its number may be another's once it ends
    try:
        line = spawn.stdout.readline()
        assert "swarm up: 100 FLS nodes in 2 process" in line, line + spawn.stderr.read()
        further = further_processes(spawn.pid)
        assert len(further) == 1, further
        held = os.pidfd_open(further[0])
        spawn.kill()
        spawn.communicate(timeout=PATIENCE)
        ended = not still_running({further[0]: held}, PATIENCE)
    finally:
        if spawn.poll() is None:
            spawn.kill()
        if held >= 0:
            with contextlib.suppress(ProcessLookupError):
                signal.pidfd_send_signal(held, signal.SIGKILL)
            os.close(held)
    assert ended, f"further process {further[0]} still running {PATIENCE} s after its launcher"


def test_a_stopped_swarm_tells_its_peers_that_every_process_nodes_left(
    context, fast_params, tmp_path
):
    # Each process deletes its DDS participant as it exits (ros.plumbing.process.exit_process), so
    # a peer drops its nodes then, not when the participant's lease runs out: an hour here.
    spawn = swazure(
        "spawn", "--cloud", "helix:100", "--beta", "0.5", "--processes", "2",
        "--params", str(fast_params), "--quiet",
        env=long_lease_environment(tmp_path, dict(os.environ)),
    )  # fmt: skip
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)

    def fls_nodes():
        names = probe.get_node_names_and_namespaces()
        return sum(1 for name, namespace in names if namespace == "/swarm" and "fls_" in name)

    def spin_until(done, seconds):
        return wait_until(done, seconds, lambda: executor.spin_once(timeout_sec=0.1))

    try:
        line = spawn.stdout.readline()
        assert line.startswith("swarm up"), line + spawn.stderr.read()
        assert spin_until(lambda: fls_nodes() == 100, PATIENCE), fls_nodes()
        code, _, err = stop(spawn)
        assert code == 0, err
        assert spin_until(lambda: fls_nodes() == 0, PATIENCE), f"{fls_nodes()} FLS nodes left"
    finally:
        if spawn.poll() is None:
            spawn.kill()
            spawn.communicate()
        executor.shutdown()
        probe.destroy_node()
