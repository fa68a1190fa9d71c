"""How our long runs allocate: memory a process frees is kept for its next block or round.

A run in blocks (``swazure evaluate``, ``swazure study``) allocates arrays of hundreds
of MB for each block and frees them after it; a swarm's process does the same with each
phase's label tables (1 GB a phase on the race car). glibc's malloc serves each such
array with a fresh ``mmap`` and gives it back to the kernel when it is freed, so every
block faults its pages in again. On a virtual machine that reports free pages to its
host, a page faulted in again is one the host must back again: on this project's
2-core machine a GiB first touched costs about 7 s, the same GiB reused 0.12 s
(BENCHMARKS.md, "Memory kept for the next block"). Kept, the race car's discovery over
ROS took 49-65 s instead of 60-77 s, and the race car at 65,536 FLSs 311-333 s instead
of 318-357 s, the same pairs.

glibc reads its malloc settings once, as a program starts, from ``GLIBC_TUNABLES``
(the glibc manual, "Tunables"): no ``mmap`` for large blocks (``glibc.malloc.mmap_max``
0), a heap that is never trimmed (``glibc.malloc.trim_threshold`` its largest), and one
arena for every thread (``glibc.malloc.arena_max`` 1). A thread's own arena grows in
heaps of 64 MB at most, so a larger block allocated on another thread (the engine's
regions and blocks side by side, its CSV writer) was mapped afresh and unmapped when
freed whatever ``mmap_max`` said: the race car at 65,536 FLSs faulted 1.47 M pages with
two regions at once, against 0.28 M with one (BENCHMARKS.md, "Two regions at once"). So
:func:`keep_freed_memory` starts the program again with them, in the same process, before
it imports anything of weight. The processes it starts inherit them: a swarm's further
processes, and its processes of one FLS, which allocate little.
"""

from __future__ import annotations

import os
import platform
import sys
from collections.abc import Mapping

#: Where glibc reads its tunables, as a program starts.
TUNABLES = "GLIBC_TUNABLES"
#: Large blocks from the heap, the heap never given back (2**64 - 1: never trimmed), and
#: one heap for every thread.
KEEP_FREED = (
    "glibc.malloc.mmap_max=0",
    f"glibc.malloc.trim_threshold={2**64 - 1}",
    "glibc.malloc.arena_max=1",
)


def keeps_freed_memory(environ: Mapping[str, str]) -> bool:
    """Whether a program started with ``environ`` keeps the memory it frees (glibc).

    Parameters
    ----------
    environ : mapping of str to str
        A process's environment (``os.environ``).

    Returns
    -------
    bool
        True when its ``GLIBC_TUNABLES`` hold every setting of :data:`KEEP_FREED`.
    """
    given = environ.get(TUNABLES, "").split(":")
    return all(setting in given for setting in KEEP_FREED)


def with_freed_memory_kept(environ: Mapping[str, str]) -> dict[str, str]:
    """``environ`` with :data:`KEEP_FREED` added to its ``GLIBC_TUNABLES``.

    Parameters
    ----------
    environ : mapping of str to str
        A process's environment; its settings of other tunables are kept, its own
        settings of these replaced.

    Returns
    -------
    dict of str to str
        A new environment; ``environ`` is not changed.
    """
    ours = {setting.split("=")[0] for setting in KEEP_FREED}
    given = [item for item in environ.get(TUNABLES, "").split(":") if item]
    kept = [item for item in given if item.split("=")[0] not in ours]
    return {**environ, TUNABLES: ":".join([*KEEP_FREED, *kept])}


def keep_freed_memory() -> None:
    """Start this program again, as the same process, keeping the memory it frees.

    Nothing happens where the program already keeps it, or where the C library is
    not glibc (musl, macOS). Call it first thing in a program's ``main``: the program
    starts over from its command line (``sys.orig_argv``, the interpreter's own
    options included), with what it has imported and done so far lost. If the program
    cannot be started again, it goes on as glibc comes.
    """
    if keeps_freed_memory(os.environ) or platform.libc_ver()[0] != "glibc":
        return
    arguments = [sys.executable, *sys.orig_argv[1:]]
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        os.execve(sys.executable, arguments, with_freed_memory_kept(os.environ))
    except OSError:
        return
