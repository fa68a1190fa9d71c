"""A program's startup parameters are program arguments, read before rclpy starts."""

from __future__ import annotations

import pytest
import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from swazure_ros.ros.plumbing.parameters import ParameterSpec
from swazure_ros.ros.plumbing.runtime import (
    DESCRIPTION_PARAMETERS,
    ParameterError,
    SwarmNode,
    declare_startup,
    startup_arguments,
    startup_parameters,
)
from swazure_ros.ros.programs import fls_program

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
