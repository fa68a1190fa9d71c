"""bench.measure_bare_nodes: bare rclpy processes on this host, seen by a probe, and their CPU."""

from bench.measure_bare_nodes import measure


def test_three_bare_processes_are_seen_and_their_cpu_is_counted(domain):
    record = measure(3, "simple", deadline=120.0, idle=0.5)
    assert record["seen"] == 3 and record["nodes"] == 3
    assert record["up_seconds"] is not None and 0 < record["up_seconds"] < 120
    # Three interpreters that imported rclpy and made a node used some CPU.
    assert record["cpu_seconds_until_up"] > 0 and record["idle_cores"] >= 0


def test_an_out_file_in_a_missing_folder_is_refused_before_measuring(tmp_path):
    import subprocess
    import sys

    from ..conftest import REPO

    missing = tmp_path / "no such folder" / "record.json"
    command = [sys.executable, "-m", "bench.measure_bare_nodes", "--nodes", "50"]
    ran = subprocess.run(
        [*command, "--discovery", "simple", "--out", str(missing)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert ran.returncode == 2 and "Traceback" not in ran.stderr
    assert ran.stderr.splitlines()[-1].endswith(f"no folder {missing.parent}")
    assert not missing.parent.exists()
