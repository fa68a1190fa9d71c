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

import numpy as np

from ..core.blocks import Budget
from ..core.clouds import resample
from ..core.conjugate_gradients import Iterate, advance
from ..core.draws import uniforms
from ..core.fans import obstructed_fans
from ..core.geometry import COMPILED_PAIRS, centre_distance
from ..core.heuristics.result import MOVE_SOURCE, PLAIN, TECHNIQUES
from ..core.measurement_graph import Measurements
from ..core.observe import observations
from ..core.paths import POLICIES, SHORTEST_LENGTH
from ..core.pipeline import RunOptions, run_engine
from ..core.sensor import COMPILED_CLASSES, DECAYING
from ..core.swarm_fit import swarm_solve
from ..protocol.loops import RunOptions as DiscoveryOptions
from ..protocol.loops import discover
from ..protocol.schedule import move_batches
from ..sim.world import WorldSpec

#: Shapes small enough to run in a moment that between them reach every kernel: a torus
#: whose pairs are all sweet (the swarm's search), the torus spread out (decaying paths)
#: and a lattice whose FLSs block one another's sight (both heuristics' moves).
SHAPES = (
    WorldSpec("torus", beta=0.5),
    WorldSpec("torus", scale=12.0, beta=0.5),
    WorldSpec("cube:125", scale=8.0, beta=0.5),
)


def warm_kernels() -> None:
    """Run every kernel once, with the argument types the programs give it.

    Each shape runs each policy (and one in blocks of a small budget, as
    ``--memory`` runs), the first the swarm's search, and each heuristic in both
    compatibility modes and as the swarm schedules its moves, fusion, and a world
    whose FLS moved; then a resample, and distances and range classes of batches big
    enough for their compiled paths, and the swarm fit's exact sums, an iteration of its conjugate
    gradients and counter-based draws (the fits are otherwise scipy's). What this leaves
    out, each process that needs it compiles at its first call (and numba
    caches): ``make test`` measured 15 kernels compiled by its workers when
    only the first shape ran.
    """
    for number, spec in enumerate(SHAPES):
        world = spec.build()
        for policy in POLICIES:
            plain = run_engine(world.swarm, world.sensor, RunOptions(policy), hold=True)
            if number == 0:  # the search's kernels take no shape-dependent path
                seen, ids = observations(plain.held.hood), world.swarm.cloud_index
                discover(seen, ids, world.sensor, world.swarm.radius, policy)
                # A run of some sources only: its tables name them (run_ids), which the
                # relaxation is compiled for apart.
                spread = DiscoveryOptions(sources=[int(fls) for fls in ids[::2]])
                discover(seen, ids, world.sensor, world.swarm.radius, policy, spread)
        # Its decaying paths both ways: SD_vis held whole, and near the pairs (a bounded
        # policy's: the regions' sight read back).
        held = RunOptions(policy, decaying="held")
        run_engine(world.swarm, world.sensor, held, budget=Budget(2**20))
        near = RunOptions(SHORTEST_LENGTH, decaying="near")
        run_engine(world.swarm, world.sensor, near, budget=Budget(2**20))
        # Fans, which a display's ends take (thousands of segments each; these have fewer).
        hood = plain.held.hood
        every = hood.pairs.select(hood.pairs.range_class == DECAYING)
        obstructed_fans(world.swarm.points, world.swarm.radius, every.first, every.second, 1)
        for technique in TECHNIQUES:
            if technique == PLAIN:
                continue
            for compat in ("text", "published"):
                options = RunOptions(policy, technique, compat=compat)
                moved = run_engine(world.swarm, world.sensor, options, plain=plain, hold=True)
                if moved.heuristic is not None and moved.evaluation is not None:
                    move_batches(moved.evaluation, moved.heuristic)
        options = RunOptions(policy, MOVE_SOURCE, source_body=True)
        run_engine(world.swarm, world.sensor, options, plain=plain)
        run_engine(world.swarm, world.sensor, RunOptions(policy, fuse=3), plain=plain)
        # An FLS steps aside, as the swarm's moves make the world's next revision.
        first = int(world.ids[0])
        _ = world.moved({first: world.position(first) + world.swarm.radius}).hood
    resample(world.swarm.points, 2 * world.swarm.size)
    # Indices into the few points held, as many as a display's neighbourhood has.
    many = np.arange(COMPILED_PAIRS, dtype=np.int64) % world.swarm.size
    centre_distance(world.swarm.points, many, many[::-1].copy())
    world.sensor.classify(np.zeros(COMPILED_CLASSES))
    # The swarm fit of a triangle measured from both ends (its draws, blocks, dots, exact
    # sums and the engine's in-place iterations), then an iteration on one FLS's rows, as a
    # process of the swarm steps its FLSs.
    points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])
    measuring, measured = np.array([0, 1, 2, 1, 0, 2]), np.array([1, 2, 0, 0, 2, 1])
    eye = np.broadcast_to(np.eye(3), (6, 3, 3))
    triangle = Measurements(measuring, measured, points[measured] - points[measuring], eye, eye)
    swarm_solve(3, triangle, samples=2)
    ones, column = np.ones((1, 3, 1)), np.ones(1)
    advance(Iterate(ones, ones, ones, ones, column, column), ones, ones, column, column, column)
    uniforms(0, [np.zeros(1, dtype=np.int64)], 1)


def main() -> int:
    """Compile, saying so first: it is the one long wait of a fresh machine."""
    print(
        "compiling the engine's numba kernels, once for this machine (a minute or so)...",
        flush=True,
    )
    began = time.perf_counter()
    warm_kernels()
    print(f"kernels compiled and cached in {time.perf_counter() - began:.0f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
