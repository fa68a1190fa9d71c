"""numba's cache on disk: a kernel's cached code goes with an edit of a kernel it calls."""

from __future__ import annotations

import json
import subprocess
import sys

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
