"""A program's startup parameters are program arguments, read before rclpy starts."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from swazure_ros.core.errors import SwazureError
from swazure_ros.ros.nodes import detector_node, fls_node, world_node
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.parameters import ParameterError, ParameterSpec
from swazure_ros.ros.plumbing.startup import (
    DESCRIPTION_PARAMETERS,
    SWARM_INSTANCE,
    declare_startup,
    program_startup,
    refuse_startup_as_parameter,
    startup_arguments,
    startup_parameters,
)
from swazure_ros.ros.programs import coordinator_program, fls_program
from swazure_ros.ros.security.auth import INSTANCE_BYTES

from ...waits import PATIENCE

FLS_ID = ParameterSpec("fls_id", -1, "id")
BETA = ParameterSpec("beta", 0.0, "beta")


def test_startup_arguments_give_each_parameter_its_type_and_leave_the_rest_default():
    specs = [FLS_ID, BETA, *DESCRIPTION_PARAMETERS[:1], ParameterSpec("accurate", False, "")]
    given = ["--fls-id", "7", "--cloud=torus:120", "--accurate", "true"]
    values = startup_parameters(given, specs)
    assert values == {"fls_id": 7, "beta": 0.0, "cloud": "torus:120", "accurate": True}


def test_startup_arguments_are_what_startup_parameters_read_back():
    values = {"fls_id": 3, "cloud": "my cloud.xyz", "beta": 0.5, "accurate": True,
              "namespace": "swarm", "track.motion": "0=circle:1,2,3,4,5"}  # fmt: skip
    arguments = startup_arguments(values, fls_program.STARTUP)
    # A default ("swarm") is left out; the rest reads back as given, beside the ROS args.
    assert "--namespace" not in arguments and "--track-motion" in arguments
    argv = ["fls", *arguments, "--ros-args", "-p", "publish_period:=0.25"]
    read = startup_parameters(remove_ros_args(argv)[1:], fls_program.STARTUP)
    assert {name: read[name] for name in values} == values


def test_no_startup_argument_means_every_default():
    assert startup_parameters([], [FLS_ID, BETA]) == {"fls_id": -1, "beta": 0.0}


def test_a_startup_argument_its_rule_refuses_is_one_clear_error():
    with pytest.raises(ParameterError, match="argument --seed must be a whole number >= 0"):
        startup_parameters(["--seed", "-3"], DESCRIPTION_PARAMETERS)


def test_a_startup_argument_of_another_type_is_one_clear_error():
    with pytest.raises(ParameterError, match="argument --fls-id: 'seven' is not a int"):
        startup_parameters(["--fls-id", "seven"], [FLS_ID, BETA])
    with pytest.raises(ParameterError, match="argument --accurate: 'yes' is not a bool"):
        startup_parameters(["--accurate", "yes"], DESCRIPTION_PARAMETERS)


def test_an_unknown_or_empty_startup_argument_is_one_clear_error():
    with pytest.raises(ParameterError, match="unknown argument '--bogus'"):
        startup_parameters(["--bogus", "1"], [FLS_ID])
    with pytest.raises(ParameterError, match="unknown argument '7'"):
        startup_parameters(["7"], [FLS_ID])
    with pytest.raises(ParameterError, match="argument --fls-id: a value is needed"):
        startup_parameters(["--fls-id"], [FLS_ID])


def test_the_node_declares_what_it_was_started_with_whatever_a_parameter_file_says(domain):
    context = Context()
    rclpy.init(args=["fls", "--ros-args", "-p", "fls_id:=99"], context=context, domain_id=domain)
    try:
        node = SwarmNode("fls_3", context=context)
        declare_startup(node, {"fls_id": 3})
        assert node.get_parameter("fls_id").value == 3
        refused = node.set_parameters([Parameter("fls_id", value=4)])[0]
        assert not refused.successful
        node.destroy_node()
    finally:
        context.try_shutdown()


#: Every program's startup parameters (their arguments before --ros-args).
PROGRAMS = {
    "fls": fls_program.STARTUP,
    "world": world_node.STARTUP,
    "coordinator": coordinator_program.STARTUP,
    "aruco_detector": detector_node.STARTUP,
}
EVERY_STARTUP = [(program, spec) for program, specs in PROGRAMS.items() for spec in specs]


@pytest.mark.parametrize(
    ("program", "spec"), EVERY_STARTUP, ids=[f"{p}-{s.name}" for p, s in EVERY_STARTUP]
)
def test_a_startup_parameter_given_as_a_ros_parameter_is_refused_naming_its_argument(
    capsys, program, spec
):
    # Issue 66: `-p swarm_instance:=...` was ignored without a word, and the program
    # then waited 60 s for the world's instance. Every startup parameter of every program.
    argv = [program, "--ros-args", "-p", f"{spec.name}:=x"]
    with pytest.raises(SystemExit) as ended:
        program_startup(argv, "usage", PROGRAMS[program])
    assert ended.value.code == 2
    said = capsys.readouterr().err
    assert said == (
        f"error: -p {spec.name}:=x: {spec.name} is not a node parameter but this program's "
        f"argument: give {spec.option} x before --ros-args\n"
    )


@pytest.mark.parametrize(
    "ros_args",
    [
        ["-p", "swarm_instance:=abc"],
        ["--param", "swarm_instance:=abc"],
        ["-p", "fls_7:swarm_instance:=abc"],  # one node's
        ["-r", "__ns:=/show", "-p", "publish_period:=0.5", "-p", "swarm_instance:=abc"],
    ],
)
def test_every_form_of_a_parameter_override_of_a_startup_parameter_is_refused(ros_args):
    with pytest.raises(ParameterError, match="give --swarm-instance abc before --ros-args"):
        refuse_startup_as_parameter(["fls", "--ros-args", *ros_args], fls_program.STARTUP)


def test_node_parameters_and_words_outside_the_ros_arguments_are_left_alone():
    argv = ["fls", "--fls-id", "3", "--ros-args", "-p", "publish_period:=0.5", "--", "-p",
            "swarm_instance:=abc"]  # fmt: skip
    refuse_startup_as_parameter(argv, fls_program.STARTUP)  # the last -p is no ROS argument


def test_a_startup_parameter_in_a_parameter_file_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text(
        "/**:\n  ros__parameters:\n    publish_period: 0.5\n"
        "/swarm/fls_3:\n  ros__parameters:\n    track:\n      motion: 0=linear:1,0,0\n"
    )
    argv = ["fls", "--ros-args", "--params-file", str(path)]
    with pytest.raises(ParameterError) as refused:
        refuse_startup_as_parameter(argv, fls_program.STARTUP)
    assert str(refused.value) == (
        f"{path}: /swarm/fls_3: track.motion is not a node parameter but this program's "
        "argument: give --track-motion VALUE before --ros-args"
    )
    path.write_text("/**:\n  ros__parameters:\n    publish_period: 0.5\n")
    refuse_startup_as_parameter(argv, fls_program.STARTUP)


def test_a_parameter_file_that_is_a_fifo_is_refused_before_rcl_would_block_on_it(tmp_path):
    fifo = tmp_path / "params.yaml"
    os.mkfifo(fifo)
    with pytest.raises(SwazureError, match="not a regular file"):
        refuse_startup_as_parameter(["fls", "--ros-args", "--params-file", str(fifo)], [])


def test_malformed_ros_arguments_are_one_line_not_rcl_s_stack(capsys):
    with pytest.raises(SystemExit) as ended:
        program_startup(["fls", "--ros-args", "-p"], "usage", fls_program.STARTUP)
    assert ended.value.code == 2
    said = capsys.readouterr().err
    assert said.startswith("error: the ROS arguments: ") and said.count("\n") == 1, said
    assert "trailing -p flag" in said and "Traceback" not in said


@pytest.mark.parametrize("text", ["zzz", "ab" * INSTANCE_BYTES + "0", "g" * 2 * INSTANCE_BYTES])
def test_a_malformed_swarm_instance_is_refused_as_its_argument_is_read(text):
    assert (
        SWARM_INSTANCE.refuses("ab" * INSTANCE_BYTES) is None
        and SWARM_INSTANCE.refuses("") is None
    )
    with pytest.raises(ParameterError) as refused:
        startup_parameters(["--swarm-instance", text], [SWARM_INSTANCE])
    assert str(refused.value) == (
        f"argument --swarm-instance must be 32 hexadecimal digits (or '' for none), got {text!r}"
    )


def test_a_program_answers_help_with_its_parameters_and_starts_no_node():
    run = subprocess.run(
        [sys.executable, "-c", "import sys; from swazure_ros.ros.programs.fls_program import "
         "main; sys.exit(main(sys.argv))", "--help"],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert run.returncode == 0 and run.stderr == "", run
    assert run.stdout.startswith("usage: ros2 run swazure_ros fls")
    for spec in fls_program.STARTUP:
        assert f"  {spec.option} ({spec.type_name}, " in run.stdout, spec.name
    for spec in (*fls_node.PARAMETERS, fls_program.JOIN_TIMEOUT):
        assert f"  {spec.name} ({spec.type_name}, " in run.stdout, spec.name
    assert "publish_period (double, 1.0)" in run.stdout
    assert "ready" not in run.stdout + run.stderr  # no node was made
    other = subprocess.run(
        [sys.executable, "-c", "import sys; from swazure_ros.ros.programs."
         "coordinator_program import main; sys.exit(main(sys.argv))", "--bogus"],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert other.returncode == 2 and "unknown argument '--bogus'" in other.stderr
    assert other.stderr.count("\n") == 1
