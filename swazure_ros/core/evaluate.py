"""The batch evaluation: every ordered blind pair of a swarm, its status, path and errors.

:func:`~.neighbourhood.neighbourhood` computes what the whole swarm shares
(neighbour pairs, line of sight, the neighbour graphs); :func:`evaluate_pairs`
applies section 5 of the spec to every ordered blind pair;
:func:`~.pair_statistics.summarise` reduces the pairs to the run's metrics
(section 6); :func:`evaluate` does all three.
"""

from __future__ import annotations

import time

import numpy as np
from numpy.typing import NDArray

from .arrays import FloatArray, IntArray
from .evaluation import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
    Evaluation,
    PairResults,
)
from .geometry import Swarm
from .hops import HopTable, estimates, hop_classes, hop_table, path_obstruction, summed_hop_errors
from .metrics import pose_errors
from .neighbourhood import Neighbourhood, neighbourhood
from .neighbours import ordered_blind_pairs
from .pair_statistics import summarise
from .path_arrays import Paths, merge_paths
from .paths import check_policy, shortest_paths
from .progress import SILENT, Progress
from .sensor import Sensor, expected_error


def evaluate_pairs(
    hood: Neighbourhood,
    policy: str,
    progress: Progress | None = None,
    blind: tuple[IntArray, IntArray] | None = None,
) -> PairResults:
    """Status, path, estimate and errors of every ordered blind pair (spec, section 5).

    ``blind``: the ordered blind pairs (source, target) (M,) to evaluate, sorted
    by source, when not all of ``hood``'s (a block of them, core.blocks).
    """
    check_policy(policy)
    progress = progress or SILENT
    source, target = blind if blind is not None else ordered_blind_pairs(hood.pairs)
    count = len(source)

    progress.start("sweet paths", count)
    sweet = shortest_paths(hood.sweet_visible, source, target, policy, progress=progress.advance)
    sweet_labels = hood.sweet_components
    connected = sweet_labels[source] == sweet_labels[target]
    fallback = ~sweet.found
    progress.start("decaying paths", int(fallback.sum()))
    decaying = shortest_paths(
        hood.any_visible, source[fallback], target[fallback], policy, progress=progress.advance
    )
    paths = merge_paths(sweet, decaying, fallback)
    status = np.full(count, NO_PATH, dtype=np.int8)
    status[paths.found] = DECAYING_PATH
    status[sweet.found] = SWEET_PATH
    reason = np.full(count, REASON_NONE, dtype=np.int8)
    reason[fallback & connected] = REASON_BLOCKED
    reason[fallback & ~connected] = REASON_NO_SWEET_PATH

    hops = hop_table(hood, paths)
    estimate, _, _ = estimates(hood, paths, hops)
    progress.start("obstruction of sweet paths", int(connected.sum()))
    radio = shortest_paths(
        hood.sweet_all,
        source[connected],
        target[connected],
        policy,
        components=sweet_labels,
        progress=progress.advance,
    )
    return pair_results(
        hood, source, target, status, reason, paths, estimate, radio, connected, hops
    )


def pair_results(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    status: NDArray[np.int8],
    reason: NDArray[np.int8],
    paths: Paths,
    estimate: FloatArray,
    radio: Paths,
    connected: NDArray[np.bool_],
    hops: HopTable | None = None,
) -> PairResults:
    """Per-pair results from statuses, paths (M pairs) and estimates (M, 3), cm.

    ``radio`` holds the policy's S_all path of each ``connected`` pair, in
    order; the errors, hop classes and obstruction follow from the geometry.
    ``hops``: ``hop_table(hood, paths)``, when the caller has it.
    """
    swarm = hood.swarm
    hops = hops or hop_table(hood, paths)
    sweet_hops, decaying_hops = hop_classes(hood, paths, hops)
    truth = swarm.points[target] - swarm.points[source]
    errors = pose_errors(estimate, truth)
    count = len(source)
    has_obstruction, obstructing = path_obstruction(hood, hood.sweet_all, radio)
    sweet_obstructed = np.zeros(count, dtype=bool)
    sweet_obstructed[connected] = has_obstruction
    obstructing_flss = np.zeros(count, dtype=np.int64)
    obstructing_flss[connected] = obstructing

    distance_error, alpha, theta, phi = errors
    return PairResults(
        predicted_error=expected_error(hood.sensor, summed_hop_errors(hood, paths, hops)),
        fused_paths=np.where(paths.found, 1, 0).astype(np.int64),
        source=source,
        target=target,
        status=status,
        reason=reason,
        hops=paths.hops,
        sweet_hops=sweet_hops,
        decaying_hops=decaying_hops,
        path_length=paths.length,
        offsets=paths.offsets,
        nodes=paths.nodes,
        estimate=estimate,
        truth=truth,
        distance_error=distance_error,
        alpha=alpha,
        theta=theta,
        phi=phi,
        sweet_connected=connected,
        sweet_obstructed=sweet_obstructed,
        obstructing_flss=obstructing_flss,
    )


def evaluate(
    swarm: Swarm, sensor: Sensor, policy: str, progress: Progress | None = None
) -> Evaluation:
    """Evaluate every ordered blind pair of ``swarm`` under ``policy``; summary included."""
    check_policy(policy)
    began = time.perf_counter()
    hood = neighbourhood(swarm, sensor, progress)
    pairs = evaluate_pairs(hood, policy, progress)
    return Evaluation(
        hood, policy, pairs, summarise(hood, policy, pairs, time.perf_counter() - began)
    )
