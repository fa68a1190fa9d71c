"""The suite's package: set up before any test module imports numpy or numba.

OpenBLAS spins its threads while they wait for work, and so does the OpenMP pool
that runs numba's parallel kernels. The suite runs several pytest-xdist workers on
few cores, and each would start a thread a core: three workers of two threads each
on this 2-core machine made a 600 x 600 Cholesky factor 5x slower than one thread did
(92 ms against 19 ms, measured under the suite's load), and every fit's test with it.
So each worker's OpenBLAS and numba get its share of the cores. The processes a test
starts (FLS processes, the CLI) inherit it: they share the same cores. A value already
set is kept; a run without workers (plain ``pytest``) keeps the libraries' own choice.
"""

import os

#: What each library reads, once, when it is loaded.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS")


def _threads_per_worker() -> int:
    """The cores this process may run on, shared among the suite's workers (at least 1)."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    return max(1, len(os.sched_getaffinity(0)) // workers)


# Here, not in conftest.py: pytest imports this package first, before numpy and numba,
# which read them when they are loaded. Only in a worker: the controller's environment
# is the workers', and it does not know their count.
if "PYTEST_XDIST_WORKER" in os.environ:
    _share = str(_threads_per_worker())
    for variable in THREAD_VARIABLES:
        os.environ.setdefault(variable, _share)
