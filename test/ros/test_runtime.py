"""How a process of the swarm (``ros.runtime.run_process``) ends when it is asked to."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

#: A process whose one node is stuck in a callback: it cannot end when asked.
STUCK = """
import sys, time
from swazure_ros.ros import runtime

runtime.STOP_LIMIT = 2.0  # the watchdog's limit, short for the test


def build(context):
    node = runtime.SwarmNode("stuck", context=context)

    def stuck_in_a_callback():
        print("stuck", flush=True)
        time.sleep(3600)

    node.create_timer(0.1, stuck_in_a_callback)
    return [node]


sys.exit(runtime.run_process(build, []))
"""


def test_a_process_that_hangs_when_asked_to_stop_prints_where_and_exits_1(domain):
    process = subprocess.Popen(
        [sys.executable, "-c", STUCK], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout is not None
        assert process.stdout.readline().strip() == "stuck"
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=30)
    finally:
        process.kill()
    assert process.returncode == 1, err
    # faulthandler's dump: every thread's stack, the stuck callback among the frames.
    assert "Timeout" in err and "stuck_in_a_callback" in err, err


#: A process whose teardown hangs: a C exit handler that never returns, as Fast DDS's
#: did in a deadlock of its own threads (eProsima/Fast-DDS#6502).
HANGING_TEARDOWN = """
import ctypes, sys, time
from swazure_ros.ros import runtime

HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_void_p)(lambda *_: time.sleep(3600))
ctypes.CDLL(None).on_exit(HANDLER, None)
print("exiting", flush=True)
runtime.exit_process(3, limit=1.0)
"""


def test_a_teardown_that_hangs_is_left_with_the_processs_own_code():
    began = time.monotonic()
    process = subprocess.run(
        [sys.executable, "-c", HANGING_TEARDOWN], capture_output=True, text=True, timeout=30
    )
    assert process.stdout.strip() == "exiting"
    assert process.returncode == 3, process.stderr
    assert "the DDS teardown did not end in 1 s" in process.stderr, process.stderr
    # Within the limit and its stack dump, long before the hanging handler would return.
    assert time.monotonic() - began < 20


#: A process whose one node fails in a callback: a bug, not bad input.
FAILING = """
import sys
from swazure_ros.ros import runtime


def build(context):
    node = runtime.SwarmNode("failing", context=context)

    def fail():
        raise ZeroDivisionError("the callback's own bug")

    node.create_timer(0.1, fail)
    return [node]


sys.exit(runtime.run_process(build, []))
"""


def test_a_callback_that_fails_ends_the_process_with_one_line_its_stack_and_code_1(domain):
    process = subprocess.run(
        [sys.executable, "-c", FAILING], capture_output=True, text=True, timeout=60
    )
    assert process.returncode == 1, process.stderr
    lines = process.stderr.splitlines()
    said = [line for line in lines if line.startswith("error: ")]
    wanted = "error: ZeroDivisionError: the callback's own bug (a bug; its stack follows)"
    assert said == [wanted], process.stderr
    # The stack after the line, down to the failing callback.
    assert "Traceback" in process.stderr.split(said[0])[1] and "in fail" in process.stderr


def test_a_value_set_while_running_is_checked_by_the_declared_rule_and_applied(context):
    from rclpy.parameter import Parameter

    from swazure_ros.ros.parameters import ParameterSpec, seconds
    from swazure_ros.ros.runtime import SwarmNode

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


def test_a_program_answers_help_with_its_parameters_and_starts_no_node():
    from swazure_ros.ros import fls_node, fls_program

    run = subprocess.run(
        [sys.executable, "-c", "import sys; from swazure_ros.ros.fls_program import main; "
         "sys.exit(main(sys.argv))", "--help"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert run.returncode == 0 and run.stderr == "", run
    assert run.stdout.startswith("usage: ros2 run swazure_ros fls")
    for spec in (*fls_program.STARTUP, *fls_node.PARAMETERS, fls_program.JOIN_TIMEOUT):
        assert f"  {spec.name} ({spec.type_name}, " in run.stdout, spec.name
    assert "publish_period (double, 1.0)" in run.stdout
    assert "ready" not in run.stdout + run.stderr  # no node was made
    other = subprocess.run(
        [sys.executable, "-c", "import sys; from swazure_ros.ros.coordinator_program import "
         "main; sys.exit(main(sys.argv))", "--bogus"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert other.returncode == 2 and "unknown argument '--bogus'" in other.stderr
    assert other.stderr.count("\n") == 1
