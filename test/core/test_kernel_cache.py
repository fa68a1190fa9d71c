"""numba's cache on disk: a kernel's cached code goes with an edit of a kernel it calls, and
with the options it was made with."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

CALLEE = """
from swazure_ros.core import jit

@jit.kernel(cache=True)
def step(x):
    return x + {increment}
"""

CALLER = """
from swazure_ros.core import jit
from .callee import step

@jit.kernel(cache=True)
def run(x):
    return step(x) * 10
"""

RUN = """
import json
from kernels.caller import run
value = run(1)
print(json.dumps({"value": value, "cache_hits": sum(run.compiled().stats.cache_hits.values())}))
"""


def run_in_a_process(folder):
    out = subprocess.run(
        [sys.executable, "-c", RUN], cwd=folder, capture_output=True, text=True, timeout=300,
        check=True,
    ).stdout  # fmt: skip
    return json.loads(out)


def test_a_kernel_is_compiled_again_when_only_a_kernel_it_calls_was_edited(tmp_path):
    package = tmp_path / "kernels"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "caller.py").write_text(CALLER)
    (package / "callee.py").write_text(CALLEE.format(increment=1))
    first = run_in_a_process(tmp_path)
    assert first == {"value": 20, "cache_hits": 0}  # compiled, and cached
    assert run_in_a_process(tmp_path) == {"value": 20, "cache_hits": 1}  # from the cache
    # The callee's module alone is edited: numba's own stamp (the caller's module) would
    # still load the caller's cached code, with the old callee inlined (20).
    (package / "callee.py").write_text(CALLEE.format(increment=2))
    assert run_in_a_process(tmp_path) == {"value": 30, "cache_hits": 0}
    assert run_in_a_process(tmp_path) == {"value": 30, "cache_hits": 1}


THREADS = """
from swazure_ros.core import jit

def _threads(out):
    for k in jit.prange(len(out)):
        out[k] = jit.get_thread_id()

parallel = jit.kernel(cache=True, parallel=True)(_threads)
serial = jit.kernel(cache=True, nogil=True)(_threads)
"""

RUN_THREADS = """
import json, sys
import numpy as np
from numba.np.ufunc.parallel import _launch_threads
_launch_threads()  # get_thread_id reads the threading layer, which a serial kernel never starts
from kernels import threads
kernel = getattr(threads, sys.argv[1])
out = np.zeros(1 << 16, dtype=np.int64)
kernel(out)
hits = sum(kernel.compiled().stats.cache_hits.values())
print(json.dumps({"threads": len(set(out.tolist())), "cache_hits": hits}))
"""


def run_kernel_in_a_process(folder, name):
    out = subprocess.run(
        [sys.executable, "-c", RUN_THREADS, name], cwd=folder, capture_output=True, text=True,
        timeout=300, check=True, env={**os.environ, "NUMBA_NUM_THREADS": "2"},
    ).stdout  # fmt: skip
    return json.loads(out)


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="a parallel kernel needs two cores here")
def test_one_source_made_parallel_and_serial_keeps_two_caches_and_runs_each_as_made(tmp_path):
    # numba keys a cached entry by signature and bytecode, not by its options: the
    # serial kernel, run first, had its code loaded by the parallel one (one thread).
    package = tmp_path / "kernels"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "threads.py").write_text(THREADS)
    assert run_kernel_in_a_process(tmp_path, "serial") == {"threads": 1, "cache_hits": 0}
    assert run_kernel_in_a_process(tmp_path, "parallel") == {"threads": 2, "cache_hits": 0}
    assert run_kernel_in_a_process(tmp_path, "parallel") == {"threads": 2, "cache_hits": 1}
    assert run_kernel_in_a_process(tmp_path, "serial") == {"threads": 1, "cache_hits": 1}
