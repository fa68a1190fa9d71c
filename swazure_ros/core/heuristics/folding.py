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
    """The plain evaluation with the heuristic's resolved pairs made SWEET; summary extended."""
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
    evaluation: Evaluation, technique: str, threshold: int = 10, compat: Compat = TEXT
) -> tuple[Evaluation, HeuristicResult | None]:
    """Apply ``technique`` to a plain evaluation; plain returns it unchanged, with no result."""
    if check_technique(technique) == PLAIN:
        return evaluation, None
    if technique == MOVE_OBSTRUCTING:
        heuristic = move_obstructing(evaluation, compat)
    else:
        heuristic = move_source(evaluation, threshold, compat)
    return apply(evaluation, heuristic), heuristic


def heuristic_facts(heuristic: HeuristicResult) -> HeuristicFacts:
    """The summary's facts of a heuristic (section 6): tried, resolved and move distances."""
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
    )
