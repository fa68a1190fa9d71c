"""How a process of ours allocates: memory it frees is kept for its next block or round.

A run in blocks (``swazure evaluate``, ``swazure study``) allocates arrays of hundreds
of MB for each block and frees them after it; a swarm's process does the same with each
phase's label tables (1 GB a phase on the race car). glibc's malloc serves each such
array with a fresh ``mmap`` and gives it back to the kernel when it is freed, so every
block faults its pages in again. On a virtual machine that reports free pages to its
host, a page faulted in again is one the host must back again: on this project's
2-core machine a GiB first touched costs about 7 s, the same GiB reused 0.12 s
(BENCHMARKS.md, "Memory kept for the next block"). Kept, the race car's discovery in
memory took 42-43 s instead of 55-61 s, and the race car at 65,536 FLSs 311-333 s
instead of 318-357 s, the same pairs.

So ``swazure evaluate``, ``swazure study``, ``swazure spawn``'s launcher and each of its
further processes keep what they free: their peak is what it was, and each keeps it
until it exits, to use again in its next run. A process of one FLS allocates little and
is left as glibc comes.
"""

from __future__ import annotations

import ctypes
import platform

#: glibc's ``mallopt`` parameters (malloc.h).
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4


def keep_freed_memory() -> bool:
    """Make this process's malloc keep what it frees, for its own later allocations.

    Large allocations come from the heap instead of ``mmap`` (``M_MMAP_MAX`` 0) and
    the heap is never trimmed (``M_TRIM_THRESHOLD`` -1), as mallopt(3) documents both.
    The process's peak is unchanged: memory is kept, not added. Call it once, early.

    Returns
    -------
    bool
        True where the C library is glibc and took both settings; False elsewhere
        (musl, macOS), where nothing changes.
    """
    if platform.libc_ver()[0] != "glibc":
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # mallopt returns 1 on success.
    return bool(mallopt(M_MMAP_MAX, 0) == 1 and mallopt(M_TRIM_THRESHOLD, -1) == 1)
