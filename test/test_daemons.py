"""The ros2 CLI's daemons a test started end with it: stopped, or killed when they hang."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from .conftest import DAEMON_TEARDOWN, ros2_daemons, running, stop_ros2_daemons

#: A stand-in for a daemon whose DDS teardown hangs: it ignores SIGTERM, and its command
#: line and environment say what ros2_daemons looks for.
HUNG_DAEMON = (
    "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
    "print('ignoring SIGTERM', flush=True); time.sleep(600)"
)


def test_a_daemon_that_ignores_sigterm_is_killed_once_its_teardown_time_is_up(domain):
    # The test's own domain (ROS_DOMAIN_ID set by the fixture): no other test's daemon is on it.
    with subprocess.Popen(
        [sys.executable, "-c", HUNG_DAEMON, "ros2cli.daemon.daemonize"],
        stdout=subprocess.PIPE,
        text=True,
    ) as hung:
        try:
            assert hung.stdout.readline() == "ignoring SIGTERM\n"
            found = ros2_daemons(domain)
            for pidfd in found.values():
                os.close(pidfd)
            assert list(found) == [hung.pid]
            began = time.monotonic()
            stop_ros2_daemons(domain)
            assert not running(hung.pid)
            assert hung.wait(timeout=5) == -9  # killed: SIGTERM alone left it running
            assert time.monotonic() - began >= DAEMON_TEARDOWN
        finally:
            if hung.poll() is None:
                hung.kill()
