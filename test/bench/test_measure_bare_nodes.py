"""bench.measure_bare_nodes: bare rclpy processes on this host, seen by a probe, and their CPU."""

from bench.measure_bare_nodes import measure


def test_three_bare_processes_are_seen_and_their_cpu_is_counted(domain):
    record = measure(3, "simple", deadline=120.0, idle=0.5)
    assert record["seen"] == 3 and record["nodes"] == 3
    assert record["up_seconds"] is not None and 0 < record["up_seconds"] < 120
    # Three interpreters that imported rclpy and made a node used some CPU.
    assert record["cpu_seconds_until_up"] > 0 and record["idle_cores"] >= 0
