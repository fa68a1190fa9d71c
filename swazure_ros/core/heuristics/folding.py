"""A heuristic's result folded into the plain run: the evaluation after it, and its summary."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import csr
from ..evaluation import NO_PATH, SWEET_PATH, Evaluation
from ..metrics import describe, pose_errors
from ..pair_statistics import summarise
from ..path_arrays import Paths, merge_paths
from ..summary import HeuristicFacts
from .compat import TEXT, Compat
from .obstructing import move_obstructing
from .result import MOVE_OBSTRUCTING, MOVE_SOURCE, PLAIN, HeuristicResult, check_technique
from .source import move_source


def apply(evaluation: Evaluation, heuristic: HeuristicResult) -> Evaluation:
    """The plain evaluation with the heuristic's resolved pairs made SWEET; summary extended.

    A resolved pair takes the heuristic's path, estimate and truth (Move
    Source's truth is from the probe position); it was measured in a moved
    swarm, so it has no predicted error (NaN) and no path length.

    Parameters
    ----------
    evaluation : Evaluation
        The plain run the heuristic was tried on.
    heuristic : HeuristicResult
        Its result over the same pairs.

    Returns
    -------
    Evaluation
        The pairs updated, the summary recomputed with :func:`heuristic_facts`.
    """
    pairs = evaluation.pairs
    resolved = heuristic.resolved
    status = pairs.status.copy()
    status[resolved] = SWEET_PATH
    plain = Paths(
        pairs.status != NO_PATH, pairs.hops, pairs.path_length, pairs.offsets, pairs.nodes
    )
    moved = heuristic.paths
    # A pair may keep its planned path without being resolved (its walk failed: walked()).
    counts = np.diff(moved.offsets)
    resolved_nodes = moved.nodes[np.repeat(resolved, counts)]
    paths = merge_paths(
        plain,
        Paths(
            moved.found[resolved],
            moved.hops[resolved],
            moved.length[resolved],
            csr.offsets(counts[resolved]),
            resolved_nodes,
        ),
        resolved,
    )
    hops = np.where(paths.found, paths.hops, 0)
    estimate = np.where(resolved[:, None], heuristic.estimate, pairs.estimate)
    truth = np.where(resolved[:, None], heuristic.truth, pairs.truth)
    sweet_hops = np.where(resolved, hops, pairs.sweet_hops)
    decaying_hops = np.where(resolved, 0, pairs.decaying_hops)
    length = pairs.path_length.copy()
    length[resolved] = np.nan
    errors = pose_errors(estimate, truth)
    updated = replace(
        pairs,
        status=status,
        hops=hops,
        sweet_hops=sweet_hops,
        decaying_hops=decaying_hops,
        path_length=length,
        offsets=paths.offsets,
        nodes=paths.nodes,
        estimate=estimate,
        truth=truth,
        distance_error=errors[0],
        alpha=errors[1],
        theta=errors[2],
        phi=errors[3],
        # A resolved pair's path was measured in a moved swarm: no prediction of its error.
        predicted_error=np.where(resolved, np.nan, pairs.predicted_error),
        fused_paths=np.where(paths.found, 1, 0).astype(np.int64),
    )
    summary = summarise(
        evaluation.hood,
        evaluation.policy,
        updated,
        evaluation.summary.seconds,
        heuristic=heuristic_facts(heuristic),
    )
    return replace(evaluation, pairs=updated, summary=summary)


def run_technique(
    evaluation: Evaluation,
    technique: str,
    threshold: int = 10,
    compat: Compat = TEXT,
    source_body: bool = False,
) -> tuple[Evaluation, HeuristicResult | None]:
    """Apply ``technique`` to a plain evaluation; plain returns it unchanged, with no result.

    Each heuristic is tried on every BLOCKED pair from the original shape
    (moves are temporary), and the pairs it resolves become SWEET.

    Parameters
    ----------
    evaluation : Evaluation
        A plain run (``evaluate.evaluate``).
    technique : {'plain', 'move-obstructing', 'move-source'}
    threshold : int, default 10
        Move Source's T: probe steps of 1 to T radii (the published settings
        are 2 and 10); unused by the others.
    compat : Compat, default TEXT
        The text's behaviour or the published code's (:data:`~.compat.PUBLISHED`).
    source_body : bool, default False
        Move Source: check that the source's own body at its probe point leaves
        the helper's view of the target clear, as the swarm flies it (the spec
        does not); unused by the others.

    Returns
    -------
    evaluation : Evaluation
        After the heuristic.
    result : HeuristicResult or None
        What it tried, resolved and moved; None for plain.

    Raises
    ------
    ValueError
        An unknown technique, or a threshold outside 1 to ``MAX_THRESHOLD``.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.clouds import cube_lattice
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> jitter = np.random.default_rng(0).normal(0.0, 0.1, (64, 3))
    >>> swarm = make_swarm(cube_lattice(64) * 2.6 + jitter, radius=1.0)  # a 4x4x4 block, cm
    >>> plain = evaluate(swarm, published, "shortest-length")
    >>> from swazure_ros.core.heuristics.folding import run_technique
    >>> plain.summary.pairs.blocked_pairs, plain.summary.pairs.no_path_pairs
    (600, 600)
    >>> after, result = run_technique(plain, "move-obstructing")
    >>> int(result.tried.sum()), int(result.resolved.sum()), after.summary.pairs.no_path_pairs
    (600, 500, 100)
    """
    if check_technique(technique) == PLAIN:
        return evaluation, None
    if technique == MOVE_OBSTRUCTING:
        heuristic = move_obstructing(evaluation, compat)
    else:
        heuristic = move_source(evaluation, threshold, compat, source_body)
    return apply(evaluation, heuristic), heuristic


def heuristic_facts(heuristic: HeuristicResult) -> HeuristicFacts:
    """The summary's facts of a heuristic (section 6): tried, resolved and move distances.

    Parameters
    ----------
    heuristic : HeuristicResult

    Returns
    -------
    HeuristicFacts
        Distances in cm: each move of the resolved pairs, of the failed ones,
        and each resolved pair's moves in all; Move Source's flown distance
        and displacement too.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.clouds import cube_lattice
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> jitter = np.random.default_rng(0).normal(0.0, 0.1, (64, 3))
    >>> swarm = make_swarm(cube_lattice(64) * 2.6 + jitter, radius=1.0)  # a 4x4x4 block, cm
    >>> plain = evaluate(swarm, published, "shortest-length")
    >>> from swazure_ros.core.heuristics.folding import heuristic_facts, run_technique
    >>> facts = heuristic_facts(run_technique(plain, "move-source", threshold=2)[1])
    >>> facts.resolved_pairs, round(facts.moved_distance.max, 6)  # at most T r = 2 cm
    (237, 2.0)
    """
    moved = heuristic.move_distance
    pairs = len(heuristic.resolved)
    owner = csr.run_of(heuristic.move_offsets)  # pair of each move
    of_resolved = heuristic.resolved[owner]
    resolved = np.flatnonzero(heuristic.resolved)
    totals = np.bincount(owner, weights=moved, minlength=pairs)[resolved]
    source = heuristic.technique == MOVE_SOURCE
    return HeuristicFacts(
        technique=heuristic.technique,
        threshold=heuristic.threshold,
        tried_pairs=int(heuristic.tried.sum()),
        resolved_pairs=len(resolved),
        moved_distance=describe(moved[of_resolved]),
        failed_moved_distance=describe(moved[~of_resolved]),
        moved_per_resolved_pair=describe(totals),
        compat=tuple(heuristic.compat.switches_on()),
        flown_distance=describe(heuristic.flown[heuristic.tried]) if source else None,
        displacement=describe(moved[of_resolved]) if source else None,
        source_body=True if heuristic.source_body else None,
    )
