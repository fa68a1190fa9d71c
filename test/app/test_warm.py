"""app/warm.py: `make setup`'s warm-up reaches every numba kernel of the package."""

from __future__ import annotations

import subprocess
import sys

from ..conftest import REPO

# In a process of its own: the suite's other tests compile kernels in this one.
REPORT_UNCOMPILED = """
import importlib, pkgutil
import swazure_ros
from swazure_ros.app.warm import warm_kernels
from swazure_ros.core.jit import Kernel

modules = [importlib.import_module(module.name)
           for module in pkgutil.walk_packages(swazure_ros.__path__, "swazure_ros.")]
warm_kernels()
kernels = {id(thing): thing for module in modules for thing in vars(module).values()
           if isinstance(thing, Kernel)}
print(len(kernels))
for kernel in kernels.values():
    if kernel._compiled is None:
        print(kernel.__module__ + "." + kernel.__name__)
"""


def test_the_warm_up_compiles_every_kernel_of_the_package():
    done = subprocess.run(
        [sys.executable, "-c", REPORT_UNCOMPILED],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    count, *uncompiled = done.stdout.split()
    # The package's kernels, every one (core.jit.kernel): a few dozen.
    assert int(count) >= 40, done.stdout
    assert not uncompiled, f"kernels the warm-up does not reach: {uncompiled}"
