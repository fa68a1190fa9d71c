"""Labels by the search's reach: what each FLS holds in one in-memory discovery of a shape.

``python -m bench.measure_labels --cloud torus:4000 --scale 3 --out record.json``: every
FLS a source, the nodes' state machines without DDS (``protocol.loops.discover``), each
process's FLSs stepped together as on ROS; beside it the engine's pairs, compared pair
for pair. The labels held are read from each table after every relaxation (a probe
wrapped around ``LabelTable.relax`` and ``together.relax_together``, this script's own).
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import record_file
from swazure_ros.core.evaluate import evaluate_pairs
from swazure_ros.core.evaluation import NO_PATH
from swazure_ros.core.observe import observations
from swazure_ros.files.atomic import atomic_write
from swazure_ros.protocol.discovery import together
from swazure_ros.protocol.discovery.labels import LabelTable
from swazure_ros.protocol.loops import discover
from swazure_ros.sim.world import WorldSpec

POLICY = "shortest-length"


def arguments() -> argparse.Namespace:
    """The command line: the cloud, its scale, beta and the record's file."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cloud", required=True)
    parser.add_argument("--scale", type=float, default=None)
    parser.add_argument("--beta", type=float, default=0.5)
    parser.add_argument("--radius", type=float, default=None, help="cm, instead of --beta")
    parser.add_argument("--resample", type=int, default=None, help="points, as --resample")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    record_file(parser, args)
    return args


def main() -> int:
    args = arguments()
    held = {"widest": 0, "most_in_a_row": 0, "at_once": 0}
    relax, relax_shared = LabelTable.relax, together.relax_together

    def count(table: LabelTable) -> None:
        counts = table.found().sum(axis=1)
        held["widest"] = max(held["widest"], table.width)
        held["most_in_a_row"] = max(held["most_in_a_row"], int(counts.max(initial=0)))
        held["at_once"] = max(held["at_once"], int(counts.sum()))

    def probed(table: LabelTable, *relaxed: Any) -> Any:
        out = relax(table, *relaxed)
        count(table)
        return out

    def probed_shared(table: LabelTable, *relaxed: Any) -> Any:
        # A process's direct table is relaxed on its cores, not by LabelTable.relax.
        out = relax_shared(table, *relaxed)
        count(table)
        return out

    LabelTable.relax = probed  # type: ignore[method-assign, assignment]
    together.relax_together = probed_shared  # type: ignore[assignment]
    small = WorldSpec("torus:120", scale=1.6, beta=args.beta).build()  # kernels loaded
    discover(observations(small.hood), small.ids, small.sensor, small.swarm.radius, POLICY)
    held.update(widest=0, most_in_a_row=0, at_once=0)
    beta = None if args.radius is not None else args.beta
    world = WorldSpec(
        args.cloud, scale=args.scale, beta=beta, radius=args.radius, resample=args.resample
    ).build()
    began = time.perf_counter()
    engine = evaluate_pairs(world.hood, POLICY)
    engine_s = time.perf_counter() - began
    seen = observations(world.hood)
    cpu, began = time.process_time(), time.perf_counter()
    outcome = discover(seen, world.ids, world.sensor, world.swarm.radius, POLICY)
    seconds, cpu = time.perf_counter() - began, time.process_time() - cpu
    ids = world.ids
    found = {(s, one.target): one for s, ones in outcome.estimates.items() for one in ones}
    identical = len(found) == len(engine)
    for pair in range(len(engine) if identical else 0):
        one = found.get((int(ids[engine.source[pair]]), int(ids[engine.target[pair]])))
        identical = (
            one is not None
            and (one.status, one.reason) == (engine.status[pair], engine.reason[pair])
            and one.path == tuple(int(ids[k]) for k in engine.path(pair))
            and (one.status == NO_PATH or np.array_equal(one.vector, engine.estimate[pair]))
        )
        if not identical:
            break
    record = {
        "cloud": args.cloud,
        "scale": args.scale,
        "resample": args.resample,
        "radius": args.radius,
        "flss": len(ids),
        "pairs": len(engine),
        "engine_s": engine_s,
        "discovery_s": seconds,
        "cpu_s": cpu,
        "rounds": outcome.rounds,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "labels_most_in_a_row": held["most_in_a_row"],
        "labels_at_once": held["at_once"],
        "row_width": held["widest"],
        "identical": identical,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(args.out, lambda path: path.write_text(json.dumps(record, indent=1)))
    print(json.dumps(record))
    return 0


if __name__ == "__main__":
    sys.exit(main())
