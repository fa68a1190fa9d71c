"""A heuristic's result folded into the plain run: the evaluation after it, and its summary."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .. import csr
from ..evaluation import NO_PATH, SWEET_PATH, Evaluation, PairResults
from ..metrics import NO_VALUES, Stats, pose_errors
from ..pair_statistics import EXACT_VALUES, summarise
from ..path_arrays import Paths, merge_paths
from ..summary import HeuristicFacts
from ..tally import RealTally
from .compat import TEXT, Compat
from .obstructing import move_obstructing
from .result import (
    MOVE_OBSTRUCTING,
    MOVE_SOURCE,
    PLAIN,
    HeuristicResult,
    PlainPairs,
    check_technique,
)
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
        The pairs updated (:func:`applied`), the summary recomputed with
        :func:`heuristic_facts`.
    """
    updated = applied(evaluation.pairs, heuristic)
    summary = summarise(
        evaluation.hood,
        evaluation.policy,
        updated,
        evaluation.summary.seconds,
        heuristic=heuristic_facts(heuristic),
    )
    return replace(evaluation, pairs=updated, summary=summary)


def applied(pairs: PairResults, heuristic: HeuristicResult) -> PairResults:
    """Plain ``pairs`` with the heuristic's resolved ones made SWEET (as :func:`apply`).

    Parameters
    ----------
    pairs : PairResults
        A plain run's pairs, or a block of them.
    heuristic : HeuristicResult
        Its result over the same pairs.

    Returns
    -------
    PairResults
        The pairs after the heuristic.
    """
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
    updated: PairResults = replace(
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
    return updated


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
    heuristic = try_technique(evaluation, technique, threshold, compat, source_body=source_body)
    return apply(evaluation, heuristic), heuristic


def try_technique(
    evaluation: PlainPairs,
    technique: str,
    threshold: int = 10,
    compat: Compat = TEXT,
    first_probe: int = 0,
    source_body: bool = False,
) -> HeuristicResult:
    """Move Obstructing or Move Source on the BLOCKED pairs of a plain run, or of a block of it.

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs (:class:`~.result.PairBlock`).
    technique : {'move-obstructing', 'move-source'}
    threshold : int, default 10
        Move Source's T.
    compat : Compat, default TEXT
    first_probe : int, default 0
        Move Source: the pairs resolved in the blocks before this one
        (:func:`~.source.move_source`).
    source_body : bool, default False
        Move Source: the source's own body at its probe point checked
        (``--source-body``, :func:`~.source.move_source`).

    Returns
    -------
    HeuristicResult
        Over ``evaluation.pairs``.
    """
    if technique == MOVE_OBSTRUCTING:
        return move_obstructing(evaluation, compat)
    return move_source(evaluation, threshold, compat, first_probe, source_body)


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
    tally = FactsTally(
        heuristic.technique,
        heuristic.threshold,
        heuristic.compat,
        source_body=heuristic.source_body,
    )
    tally.add(heuristic)
    return tally.facts()


@dataclass
class FactsTally:
    """A heuristic's summary facts (:func:`heuristic_facts`), gathered a block of pairs at a time.

    Counts are exact; each distance's statistics are exact while its values fit
    ``exact_values``, then sketched (:class:`..tally.RealTally`).
    """

    technique: str
    threshold: int | None
    compat: Compat
    exact_values: int = EXACT_VALUES
    source_body: bool = False  # Move Source: the source's body at q checked
    tried: int = 0
    resolved: int = 0
    reals: dict[str, RealTally] = field(default_factory=dict)

    def add(self, heuristic: HeuristicResult) -> None:
        """Gather the facts of ``heuristic``, the result of a block of the run's pairs."""
        moved = heuristic.move_distance
        owner = csr.run_of(heuristic.move_offsets)  # pair of each move
        of_resolved = heuristic.resolved[owner]
        resolved = np.flatnonzero(heuristic.resolved)
        totals = np.bincount(owner, weights=moved, minlength=len(heuristic.resolved))[resolved]
        self.tried += int(heuristic.tried.sum())
        self.resolved += len(resolved)
        values = {"moved": moved[of_resolved], "failed": moved[~of_resolved], "totals": totals}
        if heuristic.technique == MOVE_SOURCE:
            values["flown"] = heuristic.flown[heuristic.tried]
        for name, these in values.items():
            self.reals.setdefault(name, RealTally(self.exact_values)).add(these)

    def _stats(self, name: str) -> Stats:
        tally = self.reals.get(name)
        return NO_VALUES if tally is None else tally.describe()

    def facts(self) -> HeuristicFacts:
        """The facts of every block added."""
        source = self.technique == MOVE_SOURCE
        return HeuristicFacts(
            technique=self.technique,
            threshold=self.threshold,
            tried_pairs=self.tried,
            resolved_pairs=self.resolved,
            moved_distance=self._stats("moved"),
            failed_moved_distance=self._stats("failed"),
            moved_per_resolved_pair=self._stats("totals"),
            compat=tuple(self.compat.switches_on()),
            flown_distance=self._stats("flown") if source else None,
            displacement=self._stats("moved") if source else None,
            source_body=True if self.source_body else None,
        )
