"""Kernels compiled at their first call, or run as Python in a process started so."""

from __future__ import annotations

import os
import subprocess
import sys

#: A discovery in memory on the helix, then what the process imported.
RUN = """
import json, sys
from swazure_ros.core.evaluate import evaluate
from swazure_ros.protocol.discovery.reported import evaluation_of
from swazure_ros.protocol.loops import discover
from swazure_ros.sim.world import WorldSpec

world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
found = discover(world.seen, world.ids, world.sensor, world.swarm.radius, "shortest-length")
ours = evaluation_of(world.hood, "shortest-length", found.estimates)
assert (ours.pairs.hops > 1).sum() > 100  # paths of several hops were found
print(json.dumps({"numba": "numba" in sys.modules,
                  "estimate": ours.pairs.estimate.tolist(),
                  "nodes": ours.pairs.nodes.tolist()}))
"""


def run(disable_jit: str) -> dict:
    import json

    environment = {**os.environ, "NUMBA_DISABLE_JIT": disable_jit}
    out = subprocess.run(
        [sys.executable, "-c", RUN],
        capture_output=True, text=True, timeout=300, check=True, env=environment,
    ).stdout  # fmt: skip
    return json.loads(out)


def test_interpreted_kernels_give_the_compiled_kernels_results_without_numba():
    compiled = run("0")
    interpreted = run("1")
    assert compiled["numba"] and not interpreted["numba"]
    assert interpreted["nodes"] == compiled["nodes"]
    assert interpreted["estimate"] == compiled["estimate"]


def test_a_kernel_keeps_its_compiled_function_and_leaves_its_module_alone():
    from swazure_ros.core import geometry, jit

    kernels = {
        name: value for name, value in vars(geometry).items() if isinstance(value, jit.Kernel)
    }
    assert kernels
    name, one = next(iter(kernels.items()))
    assert one.compiled() is one.compiled()
    assert getattr(geometry, name) is one


#: Whether parallel kernels may run on two threads at once, before and after one ran.
LAYER = """
import numba
from swazure_ros.core import jit
from swazure_ros.core.threads import kernel_threads

before = jit.concurrent_kernels()


@numba.njit(parallel=True)
def total(n):
    sum = 0.0
    for i in numba.prange(n):
        sum += i
    return sum


total(100)
print(before, jit.concurrent_kernels(), numba.threading_layer(), kernel_threads(3))
"""


def concurrent(layer: str | None) -> list[str]:
    environment = {k: v for k, v in os.environ.items() if k != "NUMBA_THREADING_LAYER"}
    if layer is not None:
        environment["NUMBA_THREADING_LAYER"] = layer
    out = subprocess.run(
        [sys.executable, "-c", LAYER],
        capture_output=True, text=True, timeout=300, check=True, env=environment,
    ).stdout  # fmt: skip
    return out.split()


def test_parallel_kernels_run_on_two_threads_only_on_a_threadsafe_layer_once_loaded():
    # numba's workqueue ends the process when two threads start parallel kernels together.
    # Work that starts them then runs one piece at a time (threads.kernel_threads).
    assert concurrent("workqueue") == ["False", "False", "workqueue", "1"]
    # As this machine loads it: omp where an OpenMP runtime is found, else workqueue.
    before, after, layer, threads = concurrent(None)
    assert before == "False"  # not loaded yet: it may be workqueue
    assert after == str(layer in ("omp", "tbb"))
    assert threads == ("3" if layer in ("omp", "tbb") else "1")
