"""One shape, beta and sensor: the central least-squares fit beside the swarm's own solve of it.

Prints one JSON object: both fits' distance errors on the pairs with a sweet
path and on those that need a decaying hop, their NEES, the swarm's
iterations per solve, the fit graph's diameter in hops, the seconds of the
engine's evaluation and of each fit, one FLS's work per iteration, the
bytes one FLS sends per iteration, and with --outliers both fits on
measurements of which 10 % are turned by 20 degrees, and with --warm the
iterations a warm start needs after 1 % of the FLSs depart or move. Run by
the bench's "swarm_solve" section.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

from bench.common import fit_facts
from swazure_ros.core.conjugate_gradients import system_of
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import NO_PATH, SWEET_PATH
from swazure_ros.core.fit import LEAST_SQUARES, SWARM_FIT, refine
from swazure_ros.core.fit_measurements import fit_pairs, measurements, with_outliers
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.measurement_graph import Measurements
from swazure_ros.core.swarm_edges import edges_of
from swazure_ros.core.swarm_fit import COVARIANCE_SAMPLES, swarm_solve
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.sensors import load_sensor

OUTLIER_FRACTION, OUTLIER_DEG = 0.10, 20.0
#: FLSs whose one iteration's work is timed, and how often each.
TIMED_FLSS, TIMED_REPEATS = 200, 20


def errors(values: np.ndarray) -> dict[str, float]:
    """Mean and 95th percentile of distance errors, %; nan when there are none."""
    if len(values) == 0:
        return {"mean": float("nan"), "p95": float("nan"), "count": 0}
    return {"mean": float(np.mean(values)), "p95": float(np.percentile(values, 95)),
            "count": len(values)}  # fmt: skip


def diameter(size: int, measured: Measurements) -> int:
    """The fit graph's diameter in hops, from a double sweep of breadth-first searches."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, shortest_path

    graph = coo_matrix(
        (np.ones(len(measured)), (measured.first, measured.second)), shape=(size, size)
    ).tocsr()
    start = int(np.bincount(measured.first, minlength=size).argmax())
    far = breadth_first_order(graph, start, directed=False, return_predecessors=False)[-1]
    hops = shortest_path(graph, unweighted=True, directed=False, indices=int(far))
    return int(hops[np.isfinite(hops)].max())


def fls_work_us(size: int, measured: Measurements, columns: int) -> dict[str, float]:
    """Microseconds of one FLS's work in one iteration (its rows of H times K columns, and its
    preconditioner), timed on its own rows over its neighbours' values."""
    system = system_of(edges_of(size, measured))
    rng = np.random.default_rng(0)
    chosen = rng.choice(size, size=min(TIMED_FLSS, size), replace=False)
    times = []
    for fls in chosen.tolist():
        rows = system.matrix[3 * fls : 3 * fls + 3]
        used = np.unique(rows.indices)
        local = rows[:, used]
        values = rng.normal(size=(len(used), columns))
        block = system.preconditioner[fls]
        residual = rng.normal(size=(3, columns))
        began = time.perf_counter()
        for _ in range(TIMED_REPEATS):
            local @ values
            block @ residual
        times.append((time.perf_counter() - began) / TIMED_REPEATS * 1e6)
    return {"mean": float(np.mean(times)), "max": float(np.max(times))}


def warm_costs(size: int, measured: Measurements) -> dict[str, int]:
    """Iterations of the first solve cold, and warm after 1 % of the FLSs depart or move."""
    rng = np.random.default_rng(1)
    cold = swarm_solve(size, measured, samples=0)
    chosen = rng.choice(size, size=max(1, size // 100), replace=False)
    keep = ~(np.isin(measured.first, chosen) | np.isin(measured.second, chosen))
    names = ("first", "second", "vectors", "covariance", "information")
    departed = Measurements(*(getattr(measured, name)[keep] for name in names))
    after_departure = swarm_solve(size, departed, samples=0, start=cold.positions)
    cold_departure = swarm_solve(size, departed, samples=0)
    # A move: each chosen FLS 0.5 cm along a random direction; its measurements follow.
    shift = np.zeros((size, 3))
    direction = rng.normal(size=(len(chosen), 3))
    shift[chosen] = 0.5 * direction / np.linalg.norm(direction, axis=1, keepdims=True)
    vectors = measured.vectors + shift[measured.second] - shift[measured.first]
    moved = Measurements(measured.first, measured.second, vectors, measured.covariance,
                         measured.information)  # fmt: skip
    after_move = swarm_solve(size, moved, samples=0, start=cold.positions)
    return {
        "cold": cold.iterations[0],
        "departed_cold": cold_departure.iterations[0],
        "departed_warm": after_departure.iterations[0],
        "moved_warm": after_move.iterations[0],
        "moved_flss": len(chosen),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cloud")
    parser.add_argument("--beta", type=float, default=0.5)
    parser.add_argument("--sensor", required=True)
    parser.add_argument("--outliers", action="store_true")
    parser.add_argument("--warm", action="store_true")
    parser.add_argument(
        "--no-central", action="store_true", help="the swarm's solve alone (a swarm too large)"
    )
    args = parser.parse_args()
    swarm = make_swarm(load_cloud(args.cloud).points, beta=args.beta)
    sensor = load_sensor(args.sensor)
    began = time.perf_counter()
    plain = evaluate(swarm, sensor, "shortest-length")
    engine_s = time.perf_counter() - began
    swarm_fit = refine(plain, SWARM_FIT)
    central = None if args.no_central else refine(plain, LEAST_SQUARES)
    pairs = plain.pairs
    sweet, decaying = (
        pairs.status == SWEET_PATH,
        (pairs.status != SWEET_PATH) & (pairs.status != NO_PATH),
    )
    measured = measurements(plain.hood, fit_pairs(plain.hood))
    size = swarm.size
    result: dict[str, Any] = {
        "flss": size,
        "pairs": len(pairs),
        "measurements": len(measured),
        "diameter_hops": diameter(size, measured),
        "engine_s": engine_s,
        "central_s": None if central is None else fit_facts(central.summary).seconds,
        "swarm_s": fit_facts(swarm_fit.summary).seconds,
        "iterations": fit_facts(swarm_fit.summary).iterations,
        "samples": COVARIANCE_SAMPLES,
        "fls_work_us": fls_work_us(size, measured, COVARIANCE_SAMPLES),
        # One exchange: the FLS's three values per column, float64; the sample solve's K
        # columns are the largest message, the fit's own one column the usual.
        "message_bytes": {"fit": 3 * 8, "samples": 3 * 8 * COVARIANCE_SAMPLES},
    }
    fits = (
        [("swarm", swarm_fit)] if central is None else [("central", central), ("swarm", swarm_fit)]
    )
    for name, fitted in fits:
        error = fitted.pairs.distance_error
        result[name] = {
            "sweet": errors(error[sweet]),
            "decaying": errors(error[decaying]),
            "nees_mean": fit_facts(fitted.summary).consistency.nees.mean,
            "within_chi2_95_pct": fit_facts(fitted.summary).consistency.within_chi2_95_pct,
        }
    if central is not None:
        result["largest_difference_cm"] = float(
            np.nanmax(np.abs(swarm_fit.pairs.estimate - central.pairs.estimate))
        )
    if args.outliers and central is not None:
        measured_pairs = np.concatenate([measured.first, measured.second])
        counts = np.bincount(measured_pairs, minlength=size) // 2
        redundant = (counts[pairs.source] >= 2) & (counts[pairs.target] >= 2)
        has_path = pairs.status != NO_PATH

        def corrupt(every: Measurements) -> Measurements:
            return with_outliers(every, OUTLIER_FRACTION, OUTLIER_DEG, seed=1)

        result["outliers"] = {}
        for name, clean in fits:
            turned = refine(plain, fit_facts(clean.summary).estimator, corrupt=corrupt)
            clean_error, turned_error = clean.pairs.distance_error, turned.pairs.distance_error
            result["outliers"][name] = {
                "clean": errors(clean_error[has_path]),
                "turned": errors(turned_error[has_path]),
                "clean_redundant": errors(clean_error[has_path & redundant]),
                "turned_redundant": errors(turned_error[has_path & redundant]),
                "downweighted": fit_facts(turned.summary).downweighted,
            }
    if args.warm:
        result["warm"] = warm_costs(size, measured)
    json.dump(result, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
