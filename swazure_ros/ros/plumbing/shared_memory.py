"""A process's own Fast DDS shared-memory segments, which it removes when it leaves without DDS.

Fast DDS gives each participant a shared-memory segment of its own in
``/dev/shm`` (``fastrtps_<16 characters>``, about 0.5 MB) and a lock file beside
it (``..._el``), which the owning process holds open while it lives. DDS's
teardown removes both; a process that leaves without it (``os._exit``:
``process.leave_quietly``, or a teardown left behind in ``process.exit_process``)
left them, and ``/dev/shm`` is memory: when the kernel killed a bench (11.8 GB)
for want of memory on this 24 GB machine (2026-11-29), 5.8 GB of it was 12,600
such segments, two days of tests and benches. The owner is the one process that can tell
its segments apart without a race: the lock files it holds open are its own.
(``fastdds shm clean`` removes every segment whose lock nobody holds, which a
participant being made at that moment may not hold yet.)
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import subprocess
from collections.abc import Iterable
from pathlib import Path

#: Where Fast DDS keeps its shared memory on Linux.
SHARED_MEMORY = Path("/dev/shm")
#: A participant's segment lock (the ports' locks, ``fastrtps_port<N>_el``, are shared).
_SEGMENT_LOCK = re.compile(r"^fastrtps_[0-9a-z]{16}_el$")


def own_segments(pid: int | str = "self") -> list[Path]:
    """The Fast DDS shared-memory files that process ``pid`` owns: each segment whose
    lock file it holds open, and that lock file; [] for a process that has none or
    that cannot be looked at."""
    try:
        descriptors = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return []
    owned = []
    for descriptor in descriptors:
        with contextlib.suppress(OSError):  # closed since the listing
            target = Path(os.readlink(f"/proc/{pid}/fd/{descriptor}"))
            if target.parent == SHARED_MEMORY and _SEGMENT_LOCK.match(target.name):
                owned += [target.with_name(target.name.removesuffix("_el")), target]
    return sorted(set(owned))


def remove(paths: Iterable[Path]) -> None:
    """Remove ``paths``, those that are there. Peers that mapped a segment keep their map."""
    for path in paths:
        with contextlib.suppress(FileNotFoundError):
            path.unlink()


def kill(process: subprocess.Popen[bytes] | subprocess.Popen[str], group: bool = False) -> None:
    """Kill ``process`` (SIGKILL; with ``group``, its process group), wait for it, and remove
    the shared-memory segments it owned, which its DDS teardown never will."""
    owned = own_segments(process.pid)
    with contextlib.suppress(ProcessLookupError):
        if group:
            os.killpg(process.pid, signal.SIGKILL)
        else:
            process.kill()
    process.wait()
    remove(owned)
