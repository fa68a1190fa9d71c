"""Compile the engine's and the protocol's numba kernels once, into numba's cache on disk.

A kernel compiles at its first call (core.jit) and numba caches it beside
its module, so only the first run on a machine pays: about a minute on two
cores. ``make setup`` runs this so that a person's first ``swazure
evaluate`` takes its usual second, not a silent minute; the bench runs it
before it times anything.

    python -m swazure_ros.app.warm
"""

from __future__ import annotations

import sys
import time

from ..core.heuristics.result import TECHNIQUES
from ..core.observe import observations
from ..core.paths import POLICIES
from ..core.pipeline import RunOptions, run_engine
from ..protocol.loops import discover
from ..sim.world import WorldSpec

#: A shape small enough to run in a moment and big enough to reach every kernel.
SHAPE = WorldSpec("torus", beta=0.5)


def warm_kernels() -> None:
    """Run every kernel once on a small shape: each policy, the swarm's search, each technique.

    The fits (core.fit) are scipy's, with no kernel of their own.
    """
    world = SHAPE.build()
    for policy in POLICIES:
        plain = run_engine(world.swarm, world.sensor, RunOptions(policy), hold=True)
        discover(
            observations(plain.held.hood),
            world.swarm.cloud_index,
            world.sensor,
            world.swarm.radius,
            policy,
        )
    for technique in TECHNIQUES:
        run_engine(world.swarm, world.sensor, RunOptions(policy, technique), plain=plain)


def main() -> int:
    """Compile, saying so first: it is the one long wait of a fresh machine."""
    print(
        "compiling the engine's numba kernels, once for this machine (up to a minute)...",
        flush=True,
    )
    began = time.perf_counter()
    warm_kernels()
    print(f"kernels compiled and cached in {time.perf_counter() - began:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
