"""A swarm's node (``ros.plumbing.node.SwarmNode``): what its callbacks raise is counted and
answered, never raised into the executor; a parameter set while it runs is checked by its rule."""

from __future__ import annotations

import subprocess
import sys

import pytest
from rcl_interfaces.msg import ParameterEvent
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_parameter_events
from swazure_interfaces.srv import GetNeighbours

from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.parameters import ParameterError, ParameterSpec, seconds

from ...waits import PATIENCE
from ..conftest import make_context
from ..helpers import spin_until

#: A process whose node has a timer that fails every time, beside one that serves.
FAILING = """
import os, signal, sys
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode


def build(context, values):
    node = SwarmNode("failing", context=context)
    ticks = []

    def fail():
        raise ZeroDivisionError("the callback's own bug")

    def serve():
        ticks.append(1)
        if len(ticks) == 10:
            print(f"served {len(ticks)}, failed {node.failures['timer fail']}", flush=True)
            os.kill(os.getpid(), signal.SIGINT)

    node.create_timer(0.05, fail)
    node.create_timer(0.1, serve)
    return [node]


sys.exit(process.run_process(build, []))
"""


def test_a_timer_callback_that_fails_is_counted_and_logged_and_the_process_serves_on(domain):
    # A publish that DDS refuses raises in a timer: it must not end a process of
    # hundreds of FLS nodes (docs/security.md).
    process = subprocess.run(
        [sys.executable, "-c", FAILING], capture_output=True, text=True, timeout=PATIENCE
    )
    assert process.returncode == 0, process.stderr
    served, failed = process.stdout.split("served ")[1].split(", failed ")
    assert int(served) == 10 and int(failed) >= 10, process.stdout
    # Logged once in the run (every FAILURE_LOG_EVERY s at most), with what failed.
    logged = [line for line in process.stderr.splitlines() if "timer fail failed" in line]
    assert len(logged) == 1 and "ZeroDivisionError: the callback's own bug" in logged[0]
    assert "Traceback" not in process.stderr, process.stderr


def test_a_service_handler_that_fails_answers_why_and_the_node_serves_on(context):

    node = SwarmNode("serving", context=context)
    calls = []

    def handle(request, response):
        calls.append(request.fls_id)
        if request.fls_id == 7:
            raise RuntimeError("failed to publish")  # as an RCLError would
        response.success = True
        return response

    node.create_service(GetNeighbours, "neighbours", handle)
    client = node.create_client(GetNeighbours, "neighbours")
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    try:
        assert client.wait_for_service(timeout_sec=PATIENCE)
        answers = []
        for fls_id in (7, 3):
            future = client.call_async(GetNeighbours.Request(fls_id=fls_id))
            executor.spin_until_future_complete(future, timeout_sec=PATIENCE)
            answers.append(future.result())
        assert calls == [7, 3]
        assert not answers[0].success
        assert answers[0].message == "internal error: RuntimeError: failed to publish"
        assert answers[1].success
        assert node.failures == {"service neighbours": 1}
    finally:
        executor.shutdown()
        node.destroy_node()


def test_a_value_set_while_running_is_checked_by_the_declared_rule_and_applied(context):
    node = SwarmNode("settable", context=context)
    applied = []
    try:
        period = ParameterSpec("period", 1.0, "s", seconds())
        assert node.declare(period, applied.append) == 1.0
        assert node.declare(ParameterSpec("shape", "torus", "fixed")) == "torus"
        for bad in (-1.0, 0.0, float("nan"), float("inf")):
            [result] = node.set_parameters([Parameter("period", value=bad)])
            assert not result.successful and "period must be a positive number" in result.reason
        assert node.get_parameter("period").value == 1.0 and applied == []
        [result] = node.set_parameters([Parameter("period", value=0.25)])
        assert result.successful and applied == [0.25]
        assert node.get_parameter("period").value == 0.25
        # Declared without a way to apply a new value: read-only once running.
        [result] = node.set_parameters([Parameter("shape", value="cube")])
        assert not result.successful and "read-only" in result.reason
    finally:
        node.destroy_node()


def test_parameters_declared_together_are_one_event_and_a_wrong_type_is_refused_in_one_line(
    domain,
):
    # rclpy declares parameters an event each; a node's are declared at once, as its
    # overrides give them, and a value of the wrong type is refused naming the parameter.
    context = make_context(domain, ["--ros-args", "-p", "count:=3"])
    wrong = make_context(domain, ["--ros-args", "-p", "period:=fast"])
    probe = SwarmNode("probe", context=context)
    events: list[ParameterEvent] = []
    probe.create_subscription(
        ParameterEvent, "/parameter_events", events.append, qos_profile_parameter_events
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    specs = [
        ParameterSpec("count", 1, "how many"),
        ParameterSpec("period", 0.5, "s", seconds()),
        ParameterSpec("shape", "torus", "which"),
    ]
    nodes = []
    try:
        nodes.append(SwarmNode("together", context=context))
        assert spin_until(executor, lambda: probe.count_publishers("/parameter_events") > 1)
        assert nodes[0].declare_all(specs, {"period": print}) == [3, 0.5, "torus"]
        declared = {spec.name for spec in specs}

        def ours() -> list[ParameterEvent]:
            """The events that declared any of ``specs`` (the node's making declares others)."""
            return [
                event
                for event in events
                if event.node == "/together" and {p.name for p in event.new_parameters} & declared
            ]

        assert spin_until(executor, ours)
        executor.spin_once(timeout_sec=0.5)  # a second event, were there one, comes now
        [event] = ours()
        assert [one.name for one in event.new_parameters] == ["count", "period", "shape"]
        [result] = nodes[0].set_parameters([Parameter("shape", value="cube")])
        assert not result.successful and "read-only" in result.reason
        nodes.append(SwarmNode("wrong", context=wrong))
        with pytest.raises(ParameterError, match="'period' to 'fast'") as refused:
            nodes[1].declare_all(specs)
        assert "/wrong" in str(refused.value) and "\n" not in str(refused.value)
    finally:
        executor.shutdown()
        for node in (*nodes, probe):
            node.destroy_node()
        context.try_shutdown()
        wrong.try_shutdown()
