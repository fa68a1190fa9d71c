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
from .hop_errors import expected_error
from .hops import HopTable, estimates, hop_classes, hop_table, path_obstruction, summed_hop_errors
from .metrics import pose_errors
from .neighbourhood import Neighbourhood, neighbourhood
from .neighbours import ordered_blind_pairs
from .pair_statistics import summarise
from .path_arrays import Paths, merge_paths
from .paths import check_policy, shortest_paths
from .progress import SILENT, Progress
from .sensor import Sensor


def evaluate_pairs(
    hood: Neighbourhood,
    policy: str,
    progress: Progress | None = None,
    blind: tuple[IntArray, IntArray] | None = None,
    decaying: Paths | None = None,
) -> PairResults:
    """Status, path, estimate and errors of every ordered blind pair (spec, section 5).

    A pair takes the policy's path in S_vis (SWEET); failing that, in SD_vis
    (DECAYING, with the reason BLOCKED when S_all joins the pair out of sight,
    NO_SWEET_PATH when it does not); failing that, none (NO_PATH). The
    estimate sums the path's measured hops.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        The path policy (:mod:`.paths`).
    progress : Progress, optional
        Told of each search stage.
    blind : tuple of two (M,) ndarray of int, optional
        The ordered blind pairs (source, target) to evaluate, sorted by source,
        when not all of ``hood``'s (a block of them, :mod:`.blocks`).
    decaying : Paths, optional
        The SD_vis paths of the pairs without a sweet path in sight, in order,
        searched already (near their pairs, :mod:`.local_paths`); ``hood``
        then needs in SD_vis only the decaying pairs they hop over.

    Returns
    -------
    PairResults
        One row per pair, in the order of ``blind`` (by default, by source,
        then target); swarm indices, cm and degrees.

    Raises
    ------
    ValueError
        An unknown policy, ``blind`` pairs that are not FLSs of the swarm
        or not sorted by source, or ``decaying`` not one path per pair without
        a sweet path in sight.

    Examples
    --------
    A and C, blind to each other, have a sweet path through B, and a
    decaying one through the fourth FLS, D:

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> pairs = evaluate_pairs(neighbourhood(swarm, sensor), "fewest-hops")
    >>> pairs.source.tolist(), pairs.target.tolist(), pairs.status.tolist(), pairs.path(0)
    ([0, 2], [2, 0], [0, 0], [0, 1, 2])
    """
    check_policy(policy)
    progress = progress or SILENT
    source, target = blind if blind is not None else ordered_blind_pairs(hood.pairs)
    progress.start("sweet paths", len(source))
    sweet = shortest_paths(
        hood.sweet_visible,
        source,
        target,
        policy,
        components=hood.sweet_visible_components,
        progress=progress.advance,
    )
    sweet_labels = hood.sweet_components
    connected = sweet_labels[source] == sweet_labels[target]
    fallback = ~sweet.found
    if decaying is None:
        progress.start("decaying paths", int(fallback.sum()))
        decaying = shortest_paths(
            hood.any_visible,
            source[fallback],
            target[fallback],
            policy,
            components=hood.any_visible_components,
            progress=progress.advance,
        )
    elif len(decaying.found) != int(fallback.sum()):
        raise ValueError("`decaying` must hold one path per pair without a sweet path in sight")
    paths = merge_paths(sweet, decaying, fallback)
    status, reason = _statuses(sweet.found, paths.found, connected)
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
    """The per-pair record of M evaluated pairs, from their statuses, paths and estimates.

    The truth, the errors, hop classes, predicted errors and obstruction
    follow from the geometry; each estimate is one path's.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    source, target : (M,) ndarray of int
        The ordered pairs, swarm indices.
    status, reason : (M,) ndarray of int8
        Codes of :mod:`.evaluation` (SWEET_PATH ..., REASON_NONE ...).
    paths : Paths
        The path of each pair.
    estimate : (M, 3) ndarray of float, cm
        Each pair's estimate of its target's place seen from its source.
    radio : Paths
        The policy's S_all path of each ``connected`` pair, in order.
    connected : (M,) ndarray of bool
        The pairs that S_all joins.
    hops : HopTable, optional
        ``hop_table(hood, paths)``, when the caller has it.

    Returns
    -------
    PairResults
        The pairs' results, as :func:`evaluate_pairs` gives them.

    Raises
    ------
    ValueError
        A path hops between FLSs out of each other's reach, or a path of
        ``radio`` leaves S_all.
    """
    hops = hops or hop_table(hood, paths)
    sweet_hops, decaying_hops = hop_classes(hood, paths, hops)
    truth = hood.swarm.points[target] - hood.swarm.points[source]
    distance_error, alpha, theta, phi = pose_errors(estimate, truth)
    sweet_obstructed, obstructing_flss = _sweet_obstruction(hood, radio, connected)
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


def _statuses(
    sweet: NDArray[np.bool_], found: NDArray[np.bool_], connected: NDArray[np.bool_]
) -> tuple[NDArray[np.int8], NDArray[np.int8]]:
    """Each pair's status and reason (M,), from where a sweet path and any path was found."""
    status = np.full(len(sweet), NO_PATH, dtype=np.int8)
    status[found] = DECAYING_PATH
    status[sweet] = SWEET_PATH
    reason = np.full(len(sweet), REASON_NONE, dtype=np.int8)
    reason[~sweet & connected] = REASON_BLOCKED
    reason[~sweet & ~connected] = REASON_NO_SWEET_PATH
    return status, reason


def _sweet_obstruction(
    hood: Neighbourhood, radio: Paths, connected: NDArray[np.bool_]
) -> tuple[NDArray[np.bool_], IntArray]:
    """Whether each pair's S_all path (in ``radio`` where ``connected``) has a hop out of
    sight, and its distinct obstructing FLSs: (M,) each, False and 0 where not connected."""
    has_obstruction, obstructing = path_obstruction(hood, hood.sweet_all, radio)
    sweet_obstructed = np.zeros(len(connected), dtype=bool)
    sweet_obstructed[connected] = has_obstruction
    obstructing_flss = np.zeros(len(connected), dtype=np.int64)
    obstructing_flss[connected] = obstructing
    return sweet_obstructed, obstructing_flss


def evaluate(
    swarm: Swarm, sensor: Sensor, policy: str, progress: Progress | None = None
) -> Evaluation:
    """Evaluate every ordered blind pair of a swarm under a policy: neighbourhood, pairs, summary.

    The family's entry: :func:`~.neighbourhood.neighbourhood`, then
    :func:`evaluate_pairs`, then :func:`~.pair_statistics.summarise`, timed.

    Parameters
    ----------
    swarm : Swarm
        N FLSs: points (N, 3), cm, and radius r, cm.
    sensor : Sensor
        Ranges, cm, and error model.
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
        The path policy (:mod:`.paths`).
    progress : Progress, optional
        Told of each stage.

    Returns
    -------
    Evaluation
        The neighbourhood, the policy, every ordered blind pair's results and
        the summary (spec, section 6), whose ``seconds`` the run took.

    Raises
    ------
    ValueError
        An unknown policy.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> run = evaluate(swarm, sensor, "shortest-length")
    >>> run.summary.pairs.blind_pairs, run.summary.pairs.sweet_pct
    (2, 100.0)
    >>> run.pairs.path(1)
    [2, 1, 0]
    """
    check_policy(policy)
    began = time.perf_counter()
    hood = neighbourhood(swarm, sensor, progress)
    pairs = evaluate_pairs(hood, policy, progress)
    return Evaluation(
        hood, policy, pairs, summarise(hood, policy, pairs, time.perf_counter() - began)
    )
