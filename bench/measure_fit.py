"""One shape, beta and sensor: the paper's Shortest-Length paths beside the least-squares fit.

Prints one JSON object: one sweet hop's mean error, both estimators' errors
on the pairs with a sweet path and on those that need a decaying hop, the
fit's NEES, the engine's and the fit's seconds, and with --outliers the fit
on measurements of which 10 % are turned by 20 degrees. Run by the bench's
"least_squares" section.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from functools import partial
from typing import Any

import numpy as np

from bench.common import fit_facts
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import DECAYING_PATH, NO_PATH, SWEET_PATH
from swazure_ros.core.fit import CHI2_95_3DOF, normalized_errors, path_estimates, refine
from swazure_ros.core.fit_measurements import fit_pairs, measurements, with_outliers
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.hop_errors import measured_vectors
from swazure_ros.core.pair_fits import fit_pairs_estimates, local_estimates
from swazure_ros.core.sensor import SWEET
from swazure_ros.files.cloud_files import load_cloud
from swazure_ros.files.sensors import load_sensor

OUTLIER_FRACTION, OUTLIER_DEG = 0.10, 20.0


def errors(values: np.ndarray) -> dict[str, float]:
    """Mean and 95th percentile of distance errors, %; nan when there are none."""
    if len(values) == 0:
        return {"mean": float("nan"), "p95": float("nan"), "count": 0}
    return {
        "mean": float(np.mean(values)),
        "p95": float(np.percentile(values, 95)),
        "count": len(values),
    }


def local_run(plain: Any, count: int) -> dict[str, object]:
    """K sources' own fits: per-source ms and window size; errors beside the global fit's."""
    pairs = plain.pairs
    rng = np.random.default_rng(0)
    sources = np.sort(rng.choice(np.unique(pairs.source), size=count, replace=False))
    rows = np.flatnonzero(np.isin(pairs.source, sources) & (pairs.status != NO_PATH))
    sweet = pairs.status[rows] == SWEET_PATH
    arguments = (plain.hood, pairs.source[rows], pairs.target[rows], sweet)
    local, seconds, sizes = local_estimates(*arguments)
    whole = fit_pairs_estimates(*arguments)
    truth = pairs.truth[rows]
    beyond = np.isnan(local.estimate).any(axis=1)
    local_estimate = local.estimate.copy()
    fallback, _ = path_estimates(plain.hood, pairs)
    local_estimate[beyond] = fallback[rows][beyond]

    def pct(estimate: np.ndarray) -> np.ndarray:
        error: np.ndarray = (
            100 * np.linalg.norm(estimate - truth, axis=1) / np.linalg.norm(truth, axis=1)
        )
        return error

    result: dict[str, object] = {
        "sources": count,
        "window_flss": {"mean": float(sizes.mean()), "max": int(sizes.max())},
        "ms": {
            "mean": float(1000 * seconds.mean()),
            "p95": float(1000 * np.percentile(seconds, 95)),
            "max": float(1000 * seconds.max()),
        },
        "beyond_window": int(beyond.sum()),
    }
    for name, chosen in (("sweet", sweet), ("decaying", ~sweet)):
        result[name] = {
            "path": errors(pairs.distance_error[rows][chosen]),
            "global": errors(pct(whole.estimate)[chosen]),
            "local": errors(pct(local_estimate)[chosen]),
        }
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cloud")
    parser.add_argument("--beta", type=float, required=True)
    parser.add_argument("--sensor", required=True)
    parser.add_argument("--outliers", action="store_true")
    parser.add_argument(
        "--local",
        type=int,
        default=0,
        metavar="K",
        help="only each of K sources' own fit (seeded choice), timed per source, beside "
        "the global fit on the same pairs; run it with one BLAS thread, as an FLS would",
    )
    args = parser.parse_args()
    sensor = load_sensor(args.sensor)
    swarm = make_swarm(load_cloud(args.cloud).points, beta=args.beta)
    began = time.perf_counter()
    plain = evaluate(swarm, sensor, "shortest-length")
    engine = time.perf_counter() - began
    if args.local:
        json.dump(local_run(plain, args.local), sys.stdout)
        print()
        return 0
    began = time.perf_counter()
    fitted = refine(plain)
    fit_seconds = time.perf_counter() - began

    hood, pairs = plain.hood, plain.pairs
    hop = np.flatnonzero((hood.pairs.range_class == SWEET) & hood.visible)
    first, second = hood.pairs.first[hop], hood.pairs.second[hop]
    measured = measured_vectors(sensor, swarm.points, swarm.radius, first, second)
    truth = swarm.points[second] - swarm.points[first]
    hop_error = 100 * np.linalg.norm(measured - truth, axis=1) / np.linalg.norm(truth, axis=1)

    result: dict[str, object] = {
        "flss": swarm.size,
        "one_sweet_hop_pct": float(hop_error.mean()),
        "engine_s": engine,
        "fit_s": fit_seconds,
        "measurements": fit_facts(fitted.summary).measurements,
        "downweighted": fit_facts(fitted.summary).downweighted,
    }
    for name, status in (("sweet", SWEET_PATH), ("decaying", DECAYING_PATH)):
        rows = pairs.status == status
        result[name] = {
            "path": errors(pairs.distance_error[rows]),
            "fit": errors(fitted.pairs.distance_error[rows]),
            "alpha_path": float(np.mean(pairs.alpha[rows])) if rows.any() else float("nan"),
            "alpha_fit": float(np.mean(fitted.pairs.alpha[rows])) if rows.any() else float("nan"),
        }
    assert fitted.pairs.covariance is not None  # the fit's estimates come with theirs
    nees = normalized_errors(fitted.pairs.estimate - pairs.truth, fitted.pairs.covariance)
    known = np.isfinite(nees)
    result["nees_mean"] = float(nees[known].mean())
    result["within_chi2_95_pct"] = float(100 * (nees[known] <= CHI2_95_3DOF).mean())
    if args.outliers:
        corrupt = partial(with_outliers, fraction=OUTLIER_FRACTION, angle_deg=OUTLIER_DEG, seed=1)
        turned = refine(plain, corrupt=corrupt)
        has_path = pairs.status != NO_PATH
        # An FLS in one measured pair only has two vectors and nothing to tell a wrong one by.
        graph = measurements(hood, fit_pairs(hood))
        pairs_of = np.bincount(graph.first, minlength=swarm.size)
        redundant = has_path & (pairs_of[pairs.source] >= 2) & (pairs_of[pairs.target] >= 2)
        result["outliers"] = {
            "clean": errors(fitted.pairs.distance_error[has_path]),
            "turned": errors(turned.pairs.distance_error[has_path]),
            "clean_redundant": errors(fitted.pairs.distance_error[redundant]),
            "turned_redundant": errors(turned.pairs.distance_error[redundant]),
            "downweighted": fit_facts(turned.summary).downweighted,
        }
    json.dump(result, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
