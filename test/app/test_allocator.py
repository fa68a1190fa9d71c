"""A batch verb's process keeps the memory it frees (``app.allocator``)."""

from __future__ import annotations

import json
import platform
import subprocess
import sys

import pytest

#: Page faults of allocating, touching and freeing a 256 MB array three times, in a
#: fresh interpreter after ``SETUP``; printed as JSON.
MEASURE = """
import json, resource
import numpy as np
{setup}
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
counts = []
for _ in range(3):
    before = faults()
    block = np.ones(2**25)  # 256 MB, every page touched
    del block
    counts.append(faults() - before)
print(json.dumps({{"kept": kept, "faults": counts}}))
"""

glibc_only = pytest.mark.skipif(
    platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's; elsewhere nothing changes"
)


def _faults(setup: str) -> dict[str, object]:
    script = MEASURE.format(setup=setup)
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True, timeout=300
    )
    return json.loads(done.stdout.splitlines()[-1])


@glibc_only
def test_memory_freed_is_reused_without_faulting_its_pages_again():
    kept = _faults("from swazure_ros.app.allocator import keep_freed_memory\n"
                   "kept = keep_freed_memory()")  # fmt: skip
    assert kept["kept"] is True
    first, *again = kept["faults"]
    assert first > 100  # the first array's pages were faulted in
    assert all(count < first / 10 for count in again), kept

    # The control: as glibc comes, each array's pages are faulted in anew.
    plain = _faults("kept = None")
    first, *again = plain["faults"]
    assert all(count > first / 2 for count in again), plain


@glibc_only
def test_swazure_evaluate_keeps_its_freed_memory(tmp_path):
    # The verb's own process, after a run: what it frees is kept for the next block.
    setup = (
        "from swazure_ros.cli.main import main\n"
        f"assert main(['evaluate', '--cloud', 'torus:120', '--scale', '5', '--beta', '0.5', "
        f"'--quiet', '--out', {str(tmp_path)!r}]) == 0\n"
        "kept = True"
    )
    measured = _faults(setup)
    first, *again = measured["faults"]
    assert all(count < max(first, 100) / 10 for count in again), measured


@glibc_only
def test_swazure_spawns_launcher_keeps_its_freed_memory(domain):
    # The launcher hosts share 0 and runs the engine's comparison: after a whole
    # `spawn --compute-all` of two processes, what it frees is kept (its further process
    # makes the same call as it starts, app.share.host_share).
    setup = (
        "from swazure_ros.cli import spawn\n"
        "from swazure_ros.cli.main import build_parser\n"
        "args = build_parser(['spawn']).parse_args(['spawn', '--cloud', 'torus:120', "
        "'--scale', '5', '--beta', '0.5', '--processes', '2', '--compute-all', '--quiet'])\n"
        "assert spawn.main(args) == 0\n"
        "kept = True"
    )
    measured = _faults(setup)
    first, *again = measured["faults"]
    assert all(count < max(first, 100) / 10 for count in again), measured
