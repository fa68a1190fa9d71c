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
