"""Issue 34's `make test` target: a fresh clone's whole test command, cold setup included.

The `test_suite` section of BENCHMARKS.md (`python -m bench --sections test_suite`).
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import time
from pathlib import Path

from bench.common import REPO


def test_suite_section(
    args: argparse.Namespace, target: str = "test", clones: Path = REPO.parent
) -> list[str]:
    """Issue 34's `make test` target: a fresh clone's whole test command, cold setup included."""
    # Beside this repo, as CI clones it: the tests find ../shared from there.
    clone = clones / f"bench-clone-{os.getpid()}"
    head = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
        capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    try:
        began = time.perf_counter()
        done = subprocess.run(["make", "-C", str(clone), target], capture_output=True, text=True)
        seconds = time.perf_counter() - began
    finally:
        shutil.rmtree(clone, ignore_errors=True)
    return test_suite_lines(head, seconds, done.stdout, done.returncode)


def test_suite_lines(head: str, seconds: float, output: str, code: int) -> list[str]:
    """The section from the commit, the wall s, the output and exit code of `make test`."""
    summary = re.findall(r"=+ (.*(?:passed|failed).*) =+", output)
    outcome = summary[-1] if summary else f"no summary (make exited {code})"
    met = "yes" if code == 0 and seconds < 12 * 60 else "no"
    print(f"make test: {seconds:.0f} s, {outcome}", flush=True)
    return [
        "## `make test` from a fresh clone (issue 34)",
        "",
        f"A fresh clone of {head} beside this repo (as CI makes one), then `make test`:",
        "the venv and every pinned wheel installed, the interfaces built, ruff and mypy,",
        "then pytest on two workers. Timed from outside, one run.",
        "",
        "| commit | make test s | min | pytest | exit | target | met |",
        "| --- | ---: | ---: | --- | ---: | --- | --- |",
        f"| {head} | {seconds:.0f} | {seconds / 60:.1f} | {outcome} | {code} | < 12 min | {met} |",
        "",
    ]
