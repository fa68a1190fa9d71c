"""One shape, beta and sensor: the paper's Shortest-Length paths beside the least-squares fit.

Prints one JSON object: one sweet hop's mean error, both estimators' errors
on the pairs with a sweet path and on those that need a decaying hop, the
fit's NEES, the engine's and the fit's seconds, and with --outliers the fit
on measurements of which 10 % are turned by 20 degrees. Run by bench.py's
"least_squares" section.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from functools import partial

import numpy as np

from swazure_ros.core.clouds import load_cloud
from swazure_ros.core.evaluate import DECAYING_PATH, SWEET_PATH, evaluate
from swazure_ros.core.fit import CHI2_95_3DOF, normalized_errors, refine, with_outliers
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.sensor import SWEET, load_sensor, measured_vectors

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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("cloud")
    parser.add_argument("--beta", type=float, required=True)
    parser.add_argument("--sensor", required=True)
    parser.add_argument("--outliers", action="store_true")
    args = parser.parse_args()
    sensor = load_sensor(args.sensor)
    swarm = make_swarm(load_cloud(args.cloud).points, beta=args.beta)
    began = time.perf_counter()
    plain = evaluate(swarm, sensor, "shortest-length")
    engine = time.perf_counter() - began
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
        "measurements": fitted.summary["fit"]["measurements"],
        "downweighted": fitted.summary["fit"]["downweighted"],
    }
    for name, status in (("sweet", SWEET_PATH), ("decaying", DECAYING_PATH)):
        rows = pairs.status == status
        result[name] = {
            "path": errors(pairs.distance_error[rows]),
            "fit": errors(fitted.pairs.distance_error[rows]),
            "alpha_path": float(np.mean(pairs.alpha[rows])) if rows.any() else float("nan"),
            "alpha_fit": float(np.mean(fitted.pairs.alpha[rows])) if rows.any() else float("nan"),
        }
    nees = normalized_errors(fitted.pairs.estimate - pairs.truth, fitted.pairs.covariance)
    known = np.isfinite(nees)
    result["nees_mean"] = float(nees[known].mean())
    result["within_chi2_95_pct"] = float(100 * (nees[known] <= CHI2_95_3DOF).mean())
    if args.outliers:
        corrupt = partial(with_outliers, fraction=OUTLIER_FRACTION, angle_deg=OUTLIER_DEG, seed=1)
        turned = refine(plain, corrupt=corrupt)
        has_path = pairs.status != 2
        result["outliers"] = {
            "clean": errors(fitted.pairs.distance_error[has_path]),
            "turned": errors(turned.pairs.distance_error[has_path]),
            "downweighted": turned.summary["fit"]["downweighted"],
        }
    json.dump(result, sys.stdout)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
