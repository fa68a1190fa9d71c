"""README.md's example outputs are what the commands print today (scripts/readme_outputs.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from ..conftest import REPO, SHARED

SCRIPT = REPO / "scripts" / "readme_outputs.py"
ROS2 = Path(sys.executable).parent / "ros2"


def test_the_readmes_example_outputs_match_fresh_runs(domain):
    check = subprocess.run(
        [sys.executable, str(SCRIPT), "--check", "--skip-ros"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert check.returncode == 0, check.stdout + check.stderr
    assert "3 outputs match fresh runs" in check.stdout


def test_the_readmes_first_ros_session_matches_a_fresh_one(domain):
    # The README's first ROS example: ros2 launch, ros2 param and ros2 service call.
    if not SHARED.is_dir() or not ROS2.exists():
        pytest.skip(
            "the ros2 CLI and launch wheels live in ../shared, which is not beside the repo"
        )
    check = subprocess.run(
        [sys.executable, str(SCRIPT), "--check", "--only", "ros2-first"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert check.returncode == 0, check.stdout + check.stderr
    assert "1 outputs match fresh runs" in check.stdout


def test_a_stale_output_is_caught(domain, tmp_path):
    # The check can fail: one count changed in a copy of the README.
    stale = tmp_path / "README.md"
    text = (REPO / "README.md").read_text()
    marker = text.index("<!-- output: demo-evaluate -->")
    at = text.index("ordered blind pairs", marker)
    end = text.index("\n", at)
    stale.write_text(text[:at] + "ordered blind pairs        1" + text[end:])
    check = subprocess.run(
        [
            sys.executable,
            str(SCRIPT),
            "--check",
            "--readme",
            str(stale),
            "--only",
            "demo-evaluate",
        ],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert check.returncode == 1, check.stdout + check.stderr
    assert "stale output of demo-evaluate" in check.stderr
