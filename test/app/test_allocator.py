"""Our long runs keep the memory they free (``app.allocator``), as glibc's tunables say."""

from __future__ import annotations

import json
import os
import platform
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from swazure_ros.app.allocator import (
    KEEP_FREED,
    TUNABLES,
    keeps_freed_memory,
    with_freed_memory_kept,
)

from ..waits import PATIENCE, wait_until

#: Page faults of allocating, touching and freeing a 256 MB array three times, after
#: ``{setup}``, on the main thread and then on another, printed as JSON.
MEASURE = """
import json, resource, threading
import numpy as np
{setup}
def faults():
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt
def measured():
    counts = []
    for _ in range(3):
        before = faults()
        block = np.ones(2**25)  # 256 MB, every page touched
        del block
        counts.append(faults() - before)
    return counts
main = measured()
other = []
worker = threading.Thread(target=lambda: other.extend(measured()))
worker.start()
worker.join()
print(json.dumps({{"faults": main, "thread_faults": other}}))
"""

glibc_only = pytest.mark.skipif(
    platform.libc_ver()[0] != "glibc",
    reason="GLIBC_TUNABLES are glibc's; elsewhere nothing changes",
)


def _without_tunables() -> dict[str, str]:
    return {name: value for name, value in os.environ.items() if name != TUNABLES}


def _faults(setup: str) -> dict[str, object]:
    done = subprocess.run(
        [sys.executable, "-c", MEASURE.format(setup=setup)],
        capture_output=True, text=True, check=True, timeout=300, env=_without_tunables(),
    )  # fmt: skip
    return json.loads(done.stdout.splitlines()[-1])


def _kept(measured: dict[str, object], thread: str = "faults") -> bool:
    first, *again = measured[thread]  # type: ignore[misc]
    return all(count < max(first, 100) / 10 for count in again)


def test_our_tunables_join_the_ones_given_and_replace_theirs_of_the_same_name():
    assert not keeps_freed_memory({})
    given = {TUNABLES: "glibc.malloc.trim_threshold=5:glibc.malloc.tcache_count=2", "HOME": "/x"}
    kept = with_freed_memory_kept(given)
    assert kept[TUNABLES] == ":".join([*KEEP_FREED, "glibc.malloc.tcache_count=2"])
    assert kept["HOME"] == "/x" and keeps_freed_memory(kept)
    assert given[TUNABLES].startswith("glibc.malloc.trim_threshold=5")  # not changed
    assert with_freed_memory_kept(kept) == kept  # once


@glibc_only
def test_a_program_that_keeps_freed_memory_reuses_it_without_faulting_its_pages_again():
    # The program starts again with the tunables, as the same process, and goes on.
    measured = _faults(
        "import os\n"
        "started = os.getpid()\n"
        "from swazure_ros.app.allocator import keep_freed_memory\n"
        "keep_freed_memory()\n"
        "assert os.getpid() == started"
    )
    assert measured["faults"][0] > 100 and _kept(measured), measured  # type: ignore[index]
    # Another thread's arrays too: glibc gives a thread an arena of its own, which would
    # map each large array afresh and unmap it when freed (mmap_max or not).
    assert _kept(measured, "thread_faults"), measured
    # The control: as glibc comes, each array's pages are faulted in anew.
    plain = _faults("pass")
    assert not _kept(plain) and not _kept(plain, "thread_faults"), plain


@glibc_only
def test_swazure_evaluate_keeps_its_freed_memory(tmp_path):
    # The program `swazure evaluate` as a person starts it (main() reads sys.argv).
    measured = _faults(
        "import sys\n"
        "from swazure_ros.cli.main import main\n"
        "sys.argv = ['swazure', 'evaluate', '--cloud', 'torus:120', '--scale', '5', "
        f"'--beta', '0.5', '--quiet', '--out', {str(tmp_path)!r}]\n"
        "assert main() == 0"
    )
    assert _kept(measured), measured
    assert (tmp_path / "pairs.csv").is_file()


def _started_keeping(pid: int) -> bool:
    """Whether process ``pid`` was started with our tunables. glibc parses the variable in
    its place in the process's first environment, which /proc shows: up to its first ':'."""
    pairs = Path(f"/proc/{pid}/environ").read_bytes().split(b"\0")
    given = dict(pair.decode().split("=", 1) for pair in pairs if b"=" in pair)
    return given.get(TUNABLES, "").startswith(KEEP_FREED[0])


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(child) for child in (task / "children").read_text().split()]
    return found


@glibc_only
def test_swazure_spawn_and_its_further_processes_keep_their_freed_memory(domain):
    with subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", "--cloud", "torus:120",
         "--scale", "5", "--beta", "0.5", "--processes", "2"],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=_without_tunables(),
    ) as launcher:  # fmt: skip
        output: list[str] = []
        assert launcher.stdout is not None
        reader = threading.Thread(target=lambda: output.extend(launcher.stdout), daemon=True)
        reader.start()
        try:
            assert wait_until(lambda: any("swarm up" in line for line in output), PATIENCE)
            # The launcher started again as the same process, and its further process
            # (multiprocessing's spawn: a new program) inherited the tunables.
            assert _started_keeping(launcher.pid)
            further = [
                child for child in _children(launcher.pid)
                if b"multiprocessing" in Path(f"/proc/{child}/cmdline").read_bytes()
            ]  # fmt: skip
            assert further and all(_started_keeping(pid) for pid in further)
        finally:
            launcher.send_signal(signal.SIGTERM)
            launcher.wait(PATIENCE)
            reader.join(PATIENCE)
    assert launcher.returncode == 0
