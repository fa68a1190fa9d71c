"""README.md's example outputs are what the commands print today (scripts/readme_outputs.py)."""

from __future__ import annotations

import subprocess
import sys

from ..conftest import REPO

SCRIPT = REPO / "scripts" / "readme_outputs.py"


def test_the_readmes_example_outputs_match_fresh_runs(domain):
    check = subprocess.run(
        [sys.executable, str(SCRIPT), "--check"], capture_output=True, text=True, timeout=900
    )
    assert check.returncode == 0, check.stdout + check.stderr
    assert "3 outputs match fresh runs" in check.stdout


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
