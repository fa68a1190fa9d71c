"""The ROS tests' own helpers, where a wrong one would pass a test it should fail."""

from __future__ import annotations

import os
import signal

from .helpers import ask_ros2, run_ros2


def test_a_call_that_hangs_is_asked_again_until_it_answers(tmp_path):
    # As a `ros2 param get` whose response was lost: the first call never ends, the
    # second answers at once. A marker file tells the calls apart.
    marker = tmp_path / "asked"
    script = f"if [ -e {marker} ]; then echo answered; else touch {marker}; sleep 1000; fi"
    calls = []

    def call(timeout: float):
        result = run_ros2(["sh", "-c", script], dict(os.environ), timeout)
        calls.append(result.returncode)
        return result

    result = ask_ros2(call, call_timeout=2.0)
    assert result.returncode == 0 and result.stdout == "answered\n", result
    assert calls[0] == -signal.SIGKILL and calls[-1] == 0, calls


def test_an_answer_the_caller_does_not_take_is_asked_again(tmp_path):
    # As `ros2 param get` saying "Node not found" before the node is discovered.
    marker = tmp_path / "asked"
    script = f"if [ -e {marker} ]; then echo found; else touch {marker}; echo not found; fi"
    result = ask_ros2(
        lambda timeout: run_ros2(["sh", "-c", script], dict(os.environ), timeout),
        lambda answer: "not" not in answer.stdout,
        call_timeout=30.0,
    )
    assert result.stdout == "found\n", result
