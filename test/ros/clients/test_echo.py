"""`swazure echo` (swazure_ros.ros.clients.echo) against real publishers."""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
import time

from std_msgs.msg import String

from swazure_ros.ros.clients.echo import WAIT_NOTICE_AFTER
from swazure_ros.ros.plumbing.names import MEASUREMENTS_QOS
from swazure_ros.ros.plumbing.node import SwarmNode

from ...waits import PATIENCE, wait_until


def test_echo_with_a_type_given_gets_a_latched_message_sent_before_it_started(context):
    # A swarm at rest sent its measurements once, before the reader came. A reader made
    # before discovery found the publisher would be volatile and never get this message.
    node = SwarmNode("latched_talker", context=context)
    try:
        talker = node.create_publisher(String, "/latched_chatter", MEASUREMENTS_QOS)
        talker.publish(String(data="sent before the reader came"))
        echo = subprocess.run(
            [sys.executable, "-m", "swazure_ros.cli.main", "echo", "/latched_chatter",
             "std_msgs/msg/String", "--once", "--timeout", str(PATIENCE)],
            capture_output=True, text=True, timeout=PATIENCE + 60,
        )  # fmt: skip
    finally:
        node.destroy_node()
    assert echo.returncode == 0, echo.stderr
    assert "data: sent before the reader came" in echo.stdout, echo.stdout


def test_echo_without_a_publisher_says_once_what_it_waits_for_and_stops_cleanly_on_ctrl_c(
    domain,
):
    # An empty domain: nothing publishes the topic, nothing else is under its namespace.
    command = [sys.executable, "-m", "swazure_ros.cli.main", "echo", "/swarm/measurements"]
    said: list[str] = []
    with subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    ) as echo:
        reader = threading.Thread(target=lambda: said.extend(echo.stderr), daemon=True)
        reader.start()
        try:
            assert wait_until(lambda: any("waiting" in line for line in said), PATIENCE), said
            # A repeat would come within a grace period of the line: three are watched.
            quiet_until = time.monotonic() + 3 * WAIT_NOTICE_AFTER
            wait_until(lambda: time.monotonic() > quiet_until or len(said) > 1, PATIENCE)
            echo.send_signal(signal.SIGINT)
            echo.wait(timeout=PATIENCE)
            out = echo.stdout.read()
        finally:
            if echo.poll() is None:
                echo.kill()
        reader.join(PATIENCE)
    (line,) = [line for line in said if "waiting" in line]
    assert line.startswith("swazure echo: waiting for a publisher of /swarm/measurements")
    assert "namespace /swarm," in line and f"ROS domain {domain} " in line
    assert "no topic under /swarm seen yet" in line and "--timeout S ends the wait" in line
    assert echo.returncode == 130 and out == "", said
    # Said once, then the one line of an interrupted verb.
    assert said == [line, "swazure echo: interrupted\n"], said
