"""Move Obstructing and Move Source a block of sources at a time, in bounded memory.

A heuristic's outcome for a pair depends on nothing but the swarm's original
shape and the pair's own plain result: each pair's moves are temporary and
its own (spec, section 7, step 5), no pair sees another's, and every tie is
broken within the pair (docs/core.md, "Move Obstructing and Move Source in
blocks"). So a heuristic runs on each block of plain Swazure's pairs as
:class:`..blocks.BlockedEvaluation` makes it, reading the whole swarm's
positions, grid and sweet graphs that the block's searches read too, and
needs no other block's pairs: :class:`TechniqueBlocks`. Its pairs, its
moves and its summary are those of the run held whole
(:func:`.folding.run_technique`), in the same order.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field

from ..blocks import BlockedEvaluation
from ..evaluation import PairResults
from ..pair_statistics import PairTally, summarise
from ..progress import Progress
from ..summary import Summary
from .compat import TEXT, Compat
from .folding import FactsTally, applied, try_technique
from .result import MOVE_SOURCE, MovedPairs, PairBlock


@dataclass
class TechniqueBlocks:
    """A heuristic on a run made block by block: iterate :meth:`blocks`, then read
    :meth:`summary`, as for the plain run it wraps.

    Each block's pairs come with the heuristic's record of them
    (:class:`~.result.MovedPairs`); the carried state between blocks is the
    tallies and the count of pairs resolved so far (Move Source measures the
    k-th resolved pair's probe as FLS N + k).
    """

    plain: BlockedEvaluation
    technique: str  # MOVE_OBSTRUCTING or MOVE_SOURCE
    threshold: int = 10  # Move Source's T
    compat: Compat = TEXT
    source_body: bool = False  # Move Source: the source's body at its probe checked
    own_seconds: float = 0.0  # the heuristic's computing so far
    tally: PairTally = field(init=False)
    facts: FactsTally = field(init=False)

    def __post_init__(self) -> None:
        exact = self.plain.lean.budget.exact_values
        self.tally = PairTally(exact)
        threshold = self.threshold if self.technique == MOVE_SOURCE else None
        self.facts = FactsTally(self.technique, threshold, self.compat, exact, self.source_body)

    @property
    def seconds(self) -> float:
        """Computing so far, s: plain Swazure's (its neighbourhood and blocks) and the
        heuristic's."""
        return self.plain.seconds + self.own_seconds

    def blocks(self, progress: Progress) -> Iterator[PairResults]:
        """Each block's pairs after the heuristic, in order, tallied as they are made."""
        for pairs in self.plain.blocks(progress):
            began = time.perf_counter()
            block = PairBlock(self.plain.hood, self.plain.policy, pairs)
            heuristic = try_technique(
                block,
                self.technique,
                self.threshold,
                self.compat,
                self.facts.resolved,
                self.source_body,
            )
            moved = MovedPairs.of(applied(pairs, heuristic), heuristic)
            self.tally.add(moved)
            self.facts.add(heuristic)
            self.own_seconds += time.perf_counter() - began
            yield moved

    def summary(self) -> Summary:
        """The run's summary with the heuristic's facts, once every block has been made."""
        if self.tally.pairs != len(self.plain.lean.blind):
            raise RuntimeError("the summary of a blocked evaluation needs every block made first")
        hood, policy = self.plain.hood, self.plain.policy
        return summarise(hood, policy, self.tally, self.seconds, heuristic=self.facts.facts())
