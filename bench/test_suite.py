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

from bench.common import REPO


def test_suite_section(args: argparse.Namespace) -> list[str]:
    """Issue 34's `make test` target: a fresh clone's whole test command, cold setup included."""
    # Beside this repo, as CI clones it: the tests find ../shared from there.
    clone = REPO.parent / f"bench-clone-{os.getpid()}"
    head = subprocess.run(
        ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
        capture_output=True, text=True, check=True,
    ).stdout.strip()  # fmt: skip
    subprocess.run(["git", "clone", "-q", str(REPO), str(clone)], check=True)
    try:
        began = time.perf_counter()
        done = subprocess.run(["make", "-C", str(clone), "test"], capture_output=True, text=True)
        seconds = time.perf_counter() - began
    finally:
        shutil.rmtree(clone, ignore_errors=True)
    summary = re.findall(r"=+ (.*(?:passed|failed).*) =+", done.stdout)
    outcome = summary[-1] if summary else f"no summary (make exited {done.returncode})"
    met = "yes" if done.returncode == 0 and seconds < 12 * 60 else "no"
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
        f"| {head} | {seconds:.0f} | {seconds / 60:.1f} | {outcome} | {done.returncode} "
        f"| < 12 min | {met} |",
        "",
    ]
