"""The programs a ROS 2 user starts: `ros2 run swazure_ros ...` and `ros2 launch swazure_ros ...`.

Each test drives the real `ros2` tools (wheels from ../shared: `ros2 run`,
`ros2 launch`, `ros2 param`, `ros2 topic`, `ros2 service`) against our programs
in processes of their own, and skips where they are absent.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import CameraInfo, Image
from swazure_interfaces.msg import Detections

from swazure_ros.camera.aruco import Detector, MarkerPose, full_image, render
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import SWEET_PATH
from swazure_ros.core.frames import to_metres
from swazure_ros.files.reading import config_dir
from swazure_ros.files.sensors import load_camera
from swazure_ros.ros.convert.sensing import camera_info_message, image_message
from swazure_ros.ros.plumbing.names import DETECTIONS_QOS
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.sim.world import WorldSpec

from ...conftest import REPO, SHARED
from ...domains import configured_domains, held_domain
from ...waits import PATIENCE, wait_until
from ..helpers import (
    ECHO_LATCHED,
    ROS2_CALL_TIMEOUT,
    ask_ros2,
    echo_first,
    free_udp_port,
    long_lease_environment,
    run_ros2,
)

VENV = Path(sys.executable).parents[1]
ROS2 = VENV / "bin" / "ros2"
TRIO = REPO / "config" / "swarms" / "trio.yaml"
TRIO_ARGS = ["--cloud", str(REPO / "config/track/trio.xyz"), "--radius", "0.5"]


@pytest.fixture
def ros2_tools():
    """Skip where the real ros2 run and ros2 launch are absent."""
    if not SHARED.is_dir():
        pytest.skip(
            "the ros2 CLI and launch wheels live in ../shared, which is not beside the repo"
        )
    if not ROS2.exists():
        pytest.skip(f"{ROS2} is not installed (make setup installs it from ../shared)")
    if not (VENV / "lib" / "swazure_ros" / "fls").exists():
        pytest.skip("the venv is not an ament prefix for swazure_ros (make setup makes it one)")


def environment() -> dict[str, str]:
    """The test's domain (set by the domain fixture), with the venv as the ament prefix."""
    return dict(os.environ, AMENT_PREFIX_PATH=str(VENV), PYTHONUNBUFFERED="1")


def ros2(*args: str, timeout: float = ROS2_CALL_TIMEOUT) -> subprocess.CompletedProcess[str]:
    """Run a ros2 command to its end, or kill it at ``timeout`` (helpers.run_ros2)."""
    return run_ros2([str(ROS2), *args], environment(), timeout)


def start(*args: str, cwd: Path | None = None) -> subprocess.Popen[str]:
    """Start a long-running ros2 command (``run``, ``launch``) in a process group of its own."""
    return subprocess.Popen(
        [str(ROS2), *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=environment(),
        start_new_session=True,
    )


def stop(process: subprocess.Popen[str]) -> str:
    """SIGINT, as Ctrl-C would send; what the process printed. It must end by itself."""
    os.killpg(process.pid, signal.SIGINT)
    out, _ = process.communicate(timeout=PATIENCE)
    return out


def until(command, accept, timeout: float = PATIENCE):
    """Run ``command()`` until ``accept`` holds of its result, or the time is up; the last."""
    results = []
    wait_until(lambda: results and accept(results[-1]), timeout, lambda: results.append(command()))
    return results[-1] if results else command()


def compute_pose(source: int, target: int, timeout: float = PATIENCE):
    """`ros2 service call` of the coordinator's compute_pose, again until it succeeds."""
    request = f"{{source_id: {source}, target_id: {target}, policy: 1}}"
    command = ("service", "call", "/swarm/coordinator/compute_pose",
               "swazure_interfaces/srv/ComputePose", request)  # fmt: skip
    return ask_ros2(
        lambda call_timeout: ros2(*command, timeout=call_timeout),
        lambda result: "success=True" in result.stdout,
        timeout,
    )


def nodes() -> list[str]:
    return ros2("node", "list", "--no-daemon", "--spin-time", "2").stdout.split()


def param(
    node: str, name: str, verb: str = "get", *value: str
) -> subprocess.CompletedProcess[str]:
    """`ros2 param <verb>` of one node's parameter, asked again until the node answers.

    Each `ros2 --no-daemon` call discovers the graph anew, and waits ``--timeout`` seconds
    (1 by default) for the node; on a loaded machine that can miss a node `ros2 node list`
    has just shown ("Node not found"). The call waits 10 s, and a person asks again, as
    when it hangs (helpers.ask_ros2).
    """
    command = ("param", verb, "--no-daemon", "--timeout", "10", node, name, *value)
    return ask_ros2(
        lambda timeout: ros2(*command, timeout=timeout),
        lambda result: "Node not found" not in result.stderr,
    )


def test_ros2_run_brings_up_a_swarm_that_ros2_param_and_ros2_service_answer(ros2_tools, domain):
    # As a person starts real FLS hardware: the simulator, the coordinator, an FLS each.
    programs = [
        start("run", "swazure_ros", "world", *TRIO_ARGS),
        start("run", "swazure_ros", "coordinator", *TRIO_ARGS),
    ]
    programs += [
        start(
            "run",
            "swazure_ros",
            "fls",
            *TRIO_ARGS,
            "--fls-id",
            str(fls_id),
            "--ros-args",
            "-p",
            "publish_period:=0.25",
        )
        for fls_id in range(3)
    ]
    try:
        wanted = {"/swarm/fls_0", "/swarm/fls_1", "/swarm/fls_2", "/swarm/world",
                  "/swarm/cameras", "/swarm/coordinator"}  # fmt: skip
        listed = until(nodes, lambda names: wanted <= set(names))
        assert wanted <= set(listed), listed

        got = param("/swarm/fls_1", "publish_period")
        assert got.returncode == 0 and "Double value is: 0.25" in got.stdout, got
        described = param("/swarm/fls_1", "cloud")
        assert "trio.xyz" in described.stdout, described
        # A bad value is refused with its reason and the node keeps its own; a good one
        # is taken; what was set at the start cannot be changed. One bad value through the
        # command line (YAML's .nan is NaN): the rule's every bad value, -1, 0, NaN and
        # infinity, is refused in test/ros/plumbing/test_node.py.
        refused = param("/swarm/fls_1", "publish_period", "set", ".nan")
        said = refused.stdout + refused.stderr
        assert "Setting parameter failed" in said, refused
        assert "must be a positive number of seconds" in said, refused
        assert "Double value is: 0.25" in param("/swarm/fls_1", "publish_period").stdout
        taken = param("/swarm/fls_1", "publish_period", "set", "0.5")
        assert "Set parameter successful" in taken.stdout, taken
        assert "Double value is: 0.5" in param("/swarm/fls_1", "publish_period").stdout
        fixed = param("/swarm/fls_1", "cloud", "set", "torus")
        said = fixed.stdout + fixed.stderr
        assert "Setting parameter failed" in said and "read-only" in said, fixed
        # Each program's --help lists every parameter its node answers ros2 param for:
        # a startup one as its argument (--fls-id), the others by name.
        for program, node in (("fls", "/swarm/fls_1"), ("coordinator", "/swarm/coordinator"),
                              ("world", "/swarm/world")):  # fmt: skip
            helped = ros2("run", "swazure_ros", program, "--help")
            assert helped.returncode == 0, helped
            listing = ("param", "list", "--no-daemon", "--spin-time", "2", node)
            listed = ask_ros2(
                lambda timeout: ros2(*listing, timeout=timeout),  # noqa: B023
                lambda result: bool(result.stdout.split()),
            ).stdout.split()
            ours = set(listed) - {"use_sim_time", "start_type_description_service"}
            arguments = {name: "--" + name.replace("_", "-").replace(".", "-") for name in ours}
            assert ours and all(
                f"  {name} (" in helped.stdout or f"  {arguments[name]} (" in helped.stdout
                for name in ours
            ), (ours, helped)
        # FLS 0 is blind to FLS 2 and reaches it through its sweet neighbour FLS 1.
        call = compute_pose(0, 2)
        assert "success=True" in call.stdout and "path=[0, 1, 2]" in call.stdout, call
    finally:
        outs = [stop(process) for process in programs]
    for process, out in zip(programs, outs):
        # ros2run hands on its program's exit code: each ended by itself on Ctrl-C.
        assert process.returncode == 0, (process.args, out)
    # A standalone FLS says what it waits for, and when it has it.
    assert "waiting for its camera's first frame on /swarm/fls_1/camera/detections" in outs[3]
    assert "on the swarm's radio: " in outs[3]


def test_ros2_as_a_super_client_sees_fls_processes_that_discover_through_a_server(
    ros2_tools, domain, tmp_path, monkeypatch
):
    server = f"127.0.0.1:{free_udp_port()}"  # a port of this test's own
    spawn = subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", str(TRIO), "--per-fls",
         "--discovery-server", server, "--log-dir", str(tmp_path), "--quiet"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=environment(),
        start_new_session=True,
    )  # fmt: skip
    try:
        # As the Discovery Server tutorials set up ros2 (a super client hears every endpoint).
        monkeypatch.setenv("ROS_DISCOVERY_SERVER", server)
        monkeypatch.setenv("ROS_SUPER_CLIENT", "TRUE")
        wanted = {"/swarm/fls_0", "/swarm/fls_1", "/swarm/fls_2", "/swarm/coordinator"}
        listed = until(nodes, lambda names: wanted <= set(names))
        assert wanted <= set(listed), listed

        def publishers() -> str:
            info = ("topic", "info", "--no-daemon", "--spin-time", "2", "/swarm/measurements")
            return ros2(*info).stdout

        info = until(publishers, lambda out: "Publisher count: 3" in out)
        assert "Publisher count: 3" in info, info
        got = param("/swarm/fls_2", "fls_id")
        assert "Integer value is: 2" in got.stdout, got
        # Simple discovery finds nothing of a swarm that discovers through a server.
        monkeypatch.delenv("ROS_DISCOVERY_SERVER")
        monkeypatch.delenv("ROS_SUPER_CLIENT")
        assert not wanted & set(nodes())
    finally:
        out = stop(spawn)
    assert spawn.returncode == 0, out
    assert "Server is running" in (tmp_path / "discovery_server_0.log").read_text()


def test_an_fls_without_an_id_says_so_in_one_line(ros2_tools, domain):
    run = ros2("run", "swazure_ros", "fls", *TRIO_ARGS)
    # ros2run passes the program's exit code on, and says so on its own line.
    assert run.returncode == 2, run
    assert "--fls-id" in run.stderr and "Traceback" not in run.stderr, run.stderr
    assert run.stderr.count("\n") == 1, run.stderr
    assert "Process exited with failure 2" in run.stdout, run.stdout


#: Each program's main, as its script in lib/swazure_ros/ runs it (without ../shared).
MAINS = {
    "fls": "swazure_ros.ros.programs.fls_program",
    "world": "swazure_ros.ros.nodes.world_node",
    "coordinator": "swazure_ros.ros.programs.coordinator_program",
    "aruco_detector": "swazure_ros.ros.nodes.detector_node",
}


def program(name: str, *args: str) -> subprocess.CompletedProcess[str]:
    """Run program ``name`` to its end, as ``ros2 run swazure_ros NAME ARGS`` runs it."""
    main = f"import sys; from {MAINS[name]} import main; sys.exit(main(sys.argv))"
    return subprocess.run(
        [sys.executable, "-c", main, *args], capture_output=True, text=True, timeout=PATIENCE
    )


def swarm_key(folder: Path) -> Path:
    """A key file of the swarm's, as `swazure key` writes it."""
    from swazure_ros.ros.security.keys import new_key, write_key

    path = folder / "swarm.key"
    write_key(path, new_key())
    return path


@pytest.mark.parametrize("name", list(MAINS))
def test_a_swarm_instance_given_as_a_ros_parameter_is_refused_at_once_in_one_line(
    domain, tmp_path, name
):
    # Issue 66: `-p swarm_instance:=...` was ignored without a word; an FLS with a key
    # file then waited 60 s for the world node's announcement and failed on that.
    described = [] if name == "aruco_detector" else TRIO_ARGS
    own = ["--fls-id", "0"] if name == "fls" else []
    run = program(name, *described, *own, "--key-file", str(swarm_key(tmp_path)),
                  "--ros-args", "-p", "swarm_instance:=zzz")  # fmt: skip
    assert run.returncode == 2, run
    assert run.stderr == (
        "error: -p swarm_instance:=zzz: swarm_instance is not a node parameter but this "
        "program's argument: give --swarm-instance zzz before --ros-args\n"
    ), run.stderr
    # The right form, with the same malformed instance: refused as it is read.
    run = program(name, *described, *own, "--swarm-instance", "zzz")
    assert run.returncode == 2, run
    assert run.stderr == (
        "error: argument --swarm-instance must be 32 hexadecimal digits (or '' for none), "
        "got 'zzz'\n"
    ), run.stderr


def test_a_coordinator_round_timeout_that_is_not_a_positive_time_is_refused(domain):
    # Issue 66: 0 s (or below, or not finite) on the command line, as a ROS parameter.
    for value in ("0.0", "-1.0", ".nan", ".inf"):
        run = program("coordinator", *TRIO_ARGS, "--ros-args", "-p", f"round_timeout:={value}")
        assert run.returncode == 2, run
        assert run.stderr.startswith(
            "error: /swarm/coordinator: parameter round_timeout must be a positive number of "
            "seconds below 86400, got "
        ), run.stderr
        assert run.stderr.count("\n") == 1, run.stderr


def test_ros2_run_refuses_a_startup_parameter_given_with_p_naming_its_argument(
    ros2_tools, domain, tmp_path
):
    # As the user typed it.
    key = swarm_key(tmp_path)
    run = ros2("run", "swazure_ros", "fls", *TRIO_ARGS, "--fls-id", "0", "--key-file", str(key),
               "--ros-args", "-p", "swarm_instance:=0123")  # fmt: skip
    assert run.returncode == 2, run
    assert run.stderr.count("\n") == 1 and "give --swarm-instance 0123 before" in run.stderr
    assert "Process exited with failure 2" in run.stdout, run.stdout


@pytest.mark.parametrize("discovery", ["simple", "server"])
def test_ros2_launch_one_process_per_fls_computes_the_engines_pose(
    ros2_tools, domain, discovery, monkeypatch, tmp_path
):
    server = f"127.0.0.1:{free_udp_port()}"
    through = [f"discovery_server:={server}"] if discovery == "server" else []
    # The example by its bare name, found in the installed share folder from any folder.
    launch = start("launch", "swazure_ros", "swarm.launch.py", "swarm:=trio", "mode:=per_fls",
                   *through, cwd=tmp_path)  # fmt: skip
    if through:  # ros2 then sees the graph as a super client of the launch's server
        monkeypatch.setenv("ROS_DISCOVERY_SERVER", server)
        monkeypatch.setenv("ROS_SUPER_CLIENT", "TRUE")
    try:
        wanted = {"/swarm/fls_0", "/swarm/fls_1", "/swarm/fls_2", "/swarm/world",
                  "/swarm/cameras", "/swarm/coordinator"}  # fmt: skip
        listed = until(nodes, lambda names: wanted <= set(names))
        assert wanted <= set(listed), listed
        # A measurement in metres, in the measuring FLS's frame: FLS 1 is 8 cm from FLS 0.
        echoed = echo_first([str(ROS2), "topic", "echo", *ECHO_LATCHED, "--once",
                             "--filter", "m.source_id == 0 and len(m.poses) > 0",
                             "/swarm/measurements", "swazure_interfaces/msg/Measurements"],
                            environment())  # fmt: skip
        assert "frame_id: fls_0" in echoed and "x: 0.08" in echoed, echoed
        # Discovery by messages between three processes, each an FLS alone.
        call = compute_pose(0, 2)
        assert "success=True" in call.stdout, call
        assert "path=[0, 1, 2]" in call.stdout, call.stdout
        spec = WorldSpec(str(REPO / "config/track/trio.xyz"), scale=1.0, radius=0.5)
        engine = evaluate(spec.build().swarm, spec.sensor(), policy="shortest-length")
        pairs = engine.pairs  # FLS ids are the trio's swarm indices
        row = np.flatnonzero((pairs.source == 0) & (pairs.target == 2))[0]
        # The detections carry metres, so each hop is the engine's but for the metres'
        # last bit: the answer, in metres in the source's frame, is the engine's to 1e-12.
        assert "frame_id='fls_0'" in call.stdout, call.stdout
        text = call.stdout.split("vector=geometry_msgs.msg.Vector3(")[1].split(")")[0]
        vector = [float(part.split("=")[1]) for part in text.split(", ")]
        wanted = to_metres(pairs.estimate[row])
        assert np.allclose(vector, wanted, rtol=1e-12, atol=0), (vector, wanted)
    finally:
        out = stop(launch)
    assert launch.returncode == 0, out
    assert "process has died" not in out, out
    # Each process's output is labelled with its node's name (launch appends its own count).
    assert "[fls_0-" in out and "[fls_2-" in out and "[coordinator-" in out, out
    assert "[fls-" not in out, out


def test_ros2_launch_per_fls_takes_the_swarm_files_params_and_domain_id(
    ros2_tools, domain, monkeypatch, tmp_path
):
    # The swarm's ROS parameter file, its parameters over it, and its domain: the file's.
    (tmp_path / "params.yaml").write_text(
        "/**:\n  ros__parameters:\n    publish_period: 2.0\n    republish_period: 3.0\n"
        "/**/coordinator:\n  ros__parameters:\n    round_timeout: 7.5\n"
    )
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text(
        f"fileversion: 1\nswarm:\n  cloud: {REPO / 'config/track/trio.xyz'}\n  scale: 1\n"
        f"  radius: 0.5\n  params: params.yaml\n  domain_id: {domain}\n"
        "  parameters:\n    publish_period: 0.5\n"
    )
    # ros2 launch itself on another domain of its own: only the file brings the swarm here.
    with held_domain(configured_domains()) as elsewhere:
        monkeypatch.setenv("ROS_DOMAIN_ID", str(elsewhere))
        launch = start("launch", "swazure_ros", "swarm.launch.py", f"swarm:={swarm}",
                       "mode:=per_fls", cwd=tmp_path)  # fmt: skip
        monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
        try:
            wanted = {"/swarm/fls_0", "/swarm/fls_1", "/swarm/fls_2", "/swarm/coordinator"}
            listed = until(nodes, lambda names: wanted <= set(names))
            assert wanted <= set(listed), listed

            def value(node: str, name: str) -> str:
                return param(node, name).stdout.strip()

            assert value("/swarm/coordinator", "round_timeout") == "Double value is: 7.5"
            assert value("/swarm/fls_1", "republish_period") == "Double value is: 3.0"
            # The swarm file's own parameters win over its parameter file's.
            assert value("/swarm/fls_1", "publish_period") == "Double value is: 0.5"
        finally:
            out = stop(launch)
    assert launch.returncode == 0, out


class Lines:
    """A running process's output, line by line as it comes (a thread reads it)."""

    def __init__(self, process: subprocess.Popen[str]) -> None:
        self.process = process
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.append(line)

    def stop(self) -> str:
        """SIGINT to the process group, as Ctrl-C sends it; everything it printed."""
        os.killpg(self.process.pid, signal.SIGINT)
        self.process.wait(timeout=300)
        self._reader.join(timeout=60)
        assert self.process.stdout is not None
        self.process.stdout.close()
        return "".join(self.lines)


def launched_trio(tmp_path: Path) -> tuple[Lines, dict[str, int], Path]:
    """`ros2 launch ... swarm:=trio mode:=per_fls` up, each of its five processes ready (its
    node built): its output, its processes' ids by name (fls_0, world, ...) and its key's
    folder."""
    lines = Lines(start("launch", "swazure_ros", "swarm.launch.py", "swarm:=trio",
                        "mode:=per_fls", cwd=tmp_path))  # fmt: skip

    def ready() -> bool:
        return sum("]: ready, " in line for line in lines.lines) == 5

    if not wait_until(ready, 300):
        # Not left running on this domain, where the next test would meet it.
        raise AssertionError(lines.stop())
    # "[INFO] [fls_0-3]: process started with pid [1234]"
    found = (re.search(r"\[(\w+)-\d+\]: process started with pid \[(\d+)\]", line)
             for line in lines.lines)  # fmt: skip
    pids = {hit[1]: int(hit[2]) for hit in found if hit}
    arguments = Path(f"/proc/{pids['fls_0']}/cmdline").read_text().split("\0")
    key = Path(arguments[arguments.index("--key-file") + 1])
    assert key.name == "swarm.key" and key.parent.name.startswith("swazure-launch-"), key
    return lines, pids, key.parent


def test_ctrl_c_of_ros2_launch_per_fls_ends_every_process_cleanly_and_removes_its_key(
    ros2_tools, context, tmp_path, monkeypatch
):
    # The launch's participants on an hour's lease: a peer that drops a node was told.
    lease = long_lease_environment(tmp_path, {})
    monkeypatch.setenv("FASTRTPS_DEFAULT_PROFILES_FILE", lease["FASTRTPS_DEFAULT_PROFILES_FILE"])
    probe = SwarmNode("probe", context=context)

    def listed() -> set[str]:
        return {name for name, where in probe.get_node_names_and_namespaces() if where == "/swarm"}

    lines, pids, folder = launched_trio(tmp_path)
    try:
        assert wait_until(lambda: {"fls_0", "fls_1", "fls_2", "world", "coordinator"} <= listed(),
                          300)  # fmt: skip
        out = lines.stop()
        # Stopped with the whole swarm, no process told its peers (nobody was left to hear).
        lingering = listed()
    finally:
        if lines.process.poll() is None:
            os.killpg(lines.process.pid, signal.SIGKILL)
        probe.destroy_node()
    assert {"fls_0", "fls_1", "fls_2", "world", "coordinator"} <= lingering
    assert lines.process.returncode == 0, out
    assert out.count("process has finished cleanly") == len(pids) == 5, out
    # ros2 launch says "process has died" of any exit code but 0; nothing escalated.
    for word in ("process has died", "escalating", "did not end in", "Traceback"):
        assert word not in out, out
    assert not folder.exists()


def test_ros2_launch_removes_its_key_when_a_process_of_it_has_died(ros2_tools, domain, tmp_path):
    lines, pids, folder = launched_trio(tmp_path)
    try:
        os.kill(pids["fls_1"], signal.SIGKILL)
        died = f"process has died [pid {pids['fls_1']}, exit code -9"
        assert wait_until(lambda: any(died in line for line in lines.lines), 300)
        out = lines.stop()
    finally:
        if lines.process.poll() is None:
            os.killpg(lines.process.pid, signal.SIGKILL)
    assert out.count("process has died") == 1 and out.count("finished cleanly") == 4, out
    assert not folder.exists()


def echoed(*args: str, seconds: float) -> str:
    """What ``ros2 topic echo ARGS`` prints in ``seconds``, as a person watching it would see."""
    watched = ros2("topic", "echo", *args, timeout=seconds)
    assert watched.returncode == -signal.SIGKILL, f"ros2 topic echo ended by itself: {watched}"
    return watched.stdout


def test_ros2_launch_of_the_default_example_swarm_sees_and_answers(ros2_tools, domain, tmp_path):
    # A person's first launch: no swarm given, from a folder of their own.
    launch = start("launch", "swazure_ros", "swarm.launch.py", cwd=tmp_path)
    try:
        expected = {"/swarm/fls_0", "/swarm/fls_119", "/swarm/coordinator"}
        listed = until(nodes, lambda names: expected <= set(names))
        assert expected <= set(listed), listed
        got = param("/swarm/fls_7", "publish_period")
        # The swarm file's parameters: every FLS 0.5 s, FLS 0 0.1 s.
        assert "Double value is: 0.5" in got.stdout, got
        # The packed coordinator answers ros2 param too.
        got = param("/swarm/coordinator", "round_timeout")
        assert "Double value is: 10.0" in got.stdout, got
        helped = ros2("run", "swazure_ros", "aruco_detector", "--help")
        assert helped.returncode == 0 and "camera_file (string, " in helped.stdout, helped
        # The README's echo: every FLS's latched measurement, each seeing its neighbours.
        out = echoed(*ECHO_LATCHED, "--field", "source_id", "/swarm/measurements",
                     "swazure_interfaces/msg/Measurements", seconds=20)  # fmt: skip
        sources = {int(line) for line in out.split() if line.isdigit()}
        assert sources == set(range(120)), sorted(set(range(120)) - sources)
        # tf2's frames: one per FLS in the swarm's fixed frame, metres.
        frames = echo_first([str(ROS2), "topic", "echo", *ECHO_LATCHED, "--once", "/tf_static",
                             "tf2_msgs/msg/TFMessage"], environment())  # fmt: skip
        assert frames.count("child_frame_id: fls_") == 120, frames[:2000]
        assert "frame_id: swarm" in frames
        # A blind pair that the engine reaches by a sweet path: the swarm answers it so.
        spec = WorldSpec("torus:120", scale=5.0, beta=0.5)
        pairs = evaluate(spec.build().swarm, spec.sensor(), policy="shortest-length").pairs
        row = np.flatnonzero((pairs.source == 0) & (pairs.status == SWEET_PATH))[0]
        target, path = int(pairs.target[row]), [int(fls) for fls in pairs.path(row)]
        call = compute_pose(0, target)
        assert "success=True" in call.stdout and "status=0" in call.stdout, call.stdout
        assert f"path={path}" in call.stdout, (path, call.stdout)
    finally:
        out = stop(launch)
    assert launch.returncode == 0, out


def test_ros2_run_aruco_detector_reads_rendered_images_as_the_camera_does(ros2_tools, context):
    detector = start("run", "swazure_ros", "aruco_detector")
    camera = load_camera(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
    probe = SwarmNode("camera_driver", context=context)
    images = probe.create_publisher(Image, "image_raw", qos_profile_sensor_data)
    infos = probe.create_publisher(CameraInfo, "camera_info", qos_profile_sensor_data)
    received: dict[tuple[int, int], Detections] = {}

    def take(message: Detections) -> None:
        received[(message.header.stamp.sec, message.header.stamp.nanosec)] = message

    probe.create_subscription(Detections, "detections", take, DETECTIONS_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    in_process = Detector(camera)
    try:
        for number, distance in enumerate((55.0, 65.0, 75.0)):  # mm: the sweet range
            frame = render(camera, MarkerPose(distance), np.random.default_rng(number))
            pixels = full_image(camera, frame)
            stamp = probe.get_clock().now().to_msg()
            key = (stamp.sec, stamp.nanosec)

            def publish_and_spin(stamp=stamp, pixels=pixels):
                # Again until the detector has matched both topics.
                infos.publish(camera_info_message(camera, stamp, "fls_0_camera_optical"))
                images.publish(image_message(pixels, stamp, "fls_0_camera_optical"))
                executor.spin_once(timeout_sec=0.2)

            assert wait_until(lambda key=key: key in received, PATIENCE, publish_and_spin), (
                f"no detections of the frame at {distance} mm"
            )
            message = received[key]
            assert message.header.frame_id == "fls_0_camera_optical"
            [(marker, corners)] = in_process.markers(pixels)
            [detection] = message.detections
            position = detection.pose.pose.position
            assert detection.marker_id == marker == camera.marker_id
            # The camera's own solve, to the bit: mm in the camera, m on the wire.
            assert [position.x, position.y, position.z] == (
                in_process.solve(corners) / 1000.0
            ).tolist()
            assert abs(position.z - distance / 1000.0) < 0.05 * distance / 1000.0
    finally:
        executor.shutdown()
        probe.destroy_node()
        out = stop(detector)
    assert detector.returncode == 0, out
