"""A process's parameter overrides read without a node (``ros.overrides``) are rclpy's own."""

from __future__ import annotations

import subprocess
import sys

import pytest
import rclpy
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.context import Context
from rclpy.node import Node

from swazure_ros.ros.overrides import node_overrides
from swazure_ros.ros.parameters import ParameterSpec
from swazure_ros.ros.runtime import DESCRIPTION_PARAMETERS, ParameterError, startup_parameters

PARAMETER_FILE = """\
/**:
  ros__parameters:
    cloud: torus:120
    beta: 0.5
    accurate: true
    ids: [1, 2, 3]
    weights: [0.5, 1.5]
    flags: [true, false]
    names: [fls_a, fls_b]
/swarm/fls_3:
  ros__parameters:
    fls_id: 99
/swarm/coordinator:
  ros__parameters:
    cloud: dragon
    scale: 2.0
/*/coordinator:
  ros__parameters:
    names: [from_the_wildcard]
"""


def started_with(domain: int, *ros_args: str) -> Context:
    context = Context()
    rclpy.init(args=["program", "--ros-args", *ros_args], context=context, domain_id=domain)
    return context


def as_node_reads_them(context: Context, names: list[str]) -> dict[str, object]:
    """What a node of ``context`` gets for each name, of whatever type it was given."""
    node = Node("swazure_startup", context=context, start_parameter_services=False)
    try:
        any_type = ParameterDescriptor(dynamic_typing=True)
        return {name: node.declare_parameter(name, None, any_type).value for name in names}
    finally:
        node.destroy_node()


@pytest.mark.parametrize(
    "ros_args",
    [
        ["-p", "fls_id:=3", "-p", "cloud:=dragon", "-p", "scale:=1.5"],
        ["--params-file", "{file}"],
        # A later -p wins over the file before it, and a later file over an earlier -p.
        ["--params-file", "{file}", "-p", "beta:=0.25", "-p", "fls_id:=7"],
        ["-p", "beta:=0.25", "--params-file", "{file}"],
        ["-p", "names:=[ab, cd]", "-p", "ids:=[4]", "-r", "a:=b", "--log-level", "warn"],
        # Renamed as ros2 launch names a node: its own section and the wildcard's count.
        ["-r", "__node:=coordinator", "-r", "__ns:=/swarm", "--params-file", "{file}"],
        ["-r", "__node:=coordinator", "--params-file", "{file}", "-p", "cloud:=palm"],
    ],
)
def test_overrides_read_without_a_node_are_what_a_node_gets(domain, tmp_path, ros_args):
    path = tmp_path / "parameters.yaml"
    path.write_text(PARAMETER_FILE)
    context = started_with(domain, *(arg.replace("{file}", str(path)) for arg in ros_args))
    try:
        read = node_overrides(context, "swazure_startup")
        names = ["fls_id", "cloud", "scale", "beta", "accurate", "ids", "weights", "flags",
                 "names", "absent"]  # fmt: skip
        by_node = as_node_reads_them(context, names)
        assert read == {name: value for name, value in by_node.items() if value is not None}
        # The file's section of another node is that node's.
        assert read.get("fls_id") != 99
    finally:
        context.try_shutdown()


def test_a_process_started_without_parameters_has_no_overrides(domain):
    context = started_with(domain)
    try:
        assert node_overrides(context, "swazure_startup") == {}
        specs = [ParameterSpec("fls_id", -1, "id"), ParameterSpec("cloud", "", "cloud")]
        assert startup_parameters(context, specs) == {"fls_id": -1, "cloud": ""}
    finally:
        context.try_shutdown()


BETA = ParameterSpec("beta", 0.0, "beta")


def test_a_startup_parameter_its_rule_refuses_is_one_clear_error(domain):
    context = started_with(domain, "-p", "seed:=-3")
    try:
        with pytest.raises(ParameterError, match="parameter seed must be a whole number >= 0"):
            startup_parameters(context, DESCRIPTION_PARAMETERS)
    finally:
        context.try_shutdown()


def test_a_startup_parameter_of_another_type_is_one_clear_error(domain):
    context = started_with(domain, "-p", "fls_id:=seven", "-p", "beta:=0.5")
    try:
        with pytest.raises(ParameterError, match="parameter fls_id: 'seven' is of type STRING"):
            startup_parameters(context, [ParameterSpec("fls_id", -1, "id"), BETA])
        assert startup_parameters(context, [BETA]) == {"beta": 0.5}
    finally:
        context.try_shutdown()


READ_AND_LIST_THREADS = """
import os, rclpy
from rclpy.context import Context
from swazure_ros.ros.overrides import node_overrides
context = Context()
rclpy.init(args=["program", "--ros-args", "-p", "fls_id:=3"], context=context)
print(node_overrides(context, "swazure_startup"))
for task in os.listdir("/proc/self/task"):
    print(open(f"/proc/self/task/{task}/comm").read().strip())
"""


def test_reading_overrides_makes_no_dds_participant(domain):
    # Nothing to discover, nothing to delete: the process's first node makes the participant.
    read = subprocess.run(
        [sys.executable, "-c", READ_AND_LIST_THREADS], capture_output=True, text=True, timeout=60
    )
    assert read.returncode == 0, read.stderr
    first, *threads = read.stdout.splitlines()
    assert first == "{'fls_id': 3}"
    assert threads and not any(name.startswith("dds.") for name in threads), threads
