"""The suite's workers share the machine's cores: each worker's libraries run its share."""

import ctypes
import os
from pathlib import Path

import numpy as np
import pytest

from swazure_ros.core import jit


def _openblas_threads() -> int:
    """The threads numpy's own OpenBLAS runs, asked of the library itself."""
    libraries = sorted((Path(np.__file__).parent.parent / "numpy.libs").glob("*openblas*"))
    assert libraries, "numpy's OpenBLAS library is not beside numpy (numpy.libs)"
    blas = ctypes.CDLL(str(libraries[0]))
    names = ("scipy_openblas_get_num_threads64_", "openblas_get_num_threads64_")
    return int(getattr(blas, next(name for name in names if hasattr(blas, name)))())


def _given(variable: str) -> int:
    if "PYTEST_XDIST_WORKER" not in os.environ:
        pytest.skip("not in a pytest-xdist worker (make test runs with -n; see test/__init__.py)")
    given = int(os.environ[variable])
    assert 1 <= given <= len(os.sched_getaffinity(0))
    return given


def test_a_suite_worker_s_openblas_starts_with_the_threads_the_suite_gives_it():
    # Set before numpy was imported, or OpenBLAS would run a thread a core.
    assert _openblas_threads() == _given("OPENBLAS_NUM_THREADS")


def test_a_suite_worker_s_parallel_kernels_run_on_the_threads_the_suite_gives_them():
    given = _given("NUMBA_NUM_THREADS")
    if jit.INTERPRET:
        pytest.skip("numba's JIT is off here (NUMBA_DISABLE_JIT): kernels run as Python")
    assert jit.get_num_threads() == given
