"""`swazure echo` (swazure_ros.ros.clients.echo) against real publishers."""

from __future__ import annotations

import subprocess
import sys

from std_msgs.msg import String

from swazure_ros.ros.plumbing.names import MEASUREMENTS_QOS
from swazure_ros.ros.plumbing.runtime import SwarmNode

from ...waits import PATIENCE


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
