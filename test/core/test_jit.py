"""Kernels compiled at their first call, or run as Python in a process that asks."""

from __future__ import annotations

import subprocess
import sys

#: A discovery in memory on the helix, then what the process imported.
RUN = """
import json, sys
from swazure_ros.core import jit
{setup}
from swazure_ros.core.evaluate import evaluate
from swazure_ros.protocol.discovery.estimate import evaluation_of
from swazure_ros.protocol.loops import discover
from swazure_ros.sim.world import WorldSpec

world = WorldSpec("torus:120", scale=1.6, beta=0.5).build()
found = discover(world.seen, world.ids, world.sensor, world.swarm.radius, "shortest-length")
ours = evaluation_of(world.hood, "shortest-length", found.estimates)
assert (ours.pairs.hops > 1).sum() > 100  # paths of several hops were found
print(json.dumps({{"numba": "numba" in sys.modules,
                  "estimate": ours.pairs.estimate.tolist(),
                  "nodes": ours.pairs.nodes.tolist()}}))
"""


def run(setup: str) -> dict:
    import json

    out = subprocess.run(
        [sys.executable, "-c", RUN.format(setup=setup)],
        capture_output=True, text=True, timeout=300, check=True,
    ).stdout  # fmt: skip
    return json.loads(out)


def test_interpreted_kernels_give_the_compiled_kernels_results_without_numba():
    compiled = run("")
    interpreted = run("jit.interpret()")
    assert compiled["numba"] and not interpreted["numba"]
    assert interpreted["nodes"] == compiled["nodes"]
    assert interpreted["estimate"] == compiled["estimate"]
