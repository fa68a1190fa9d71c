"""The engine at display scale: a swarm's pairs evaluated in blocks, in bounded memory.

:func:`evaluate` in :mod:`.evaluate` holds every neighbour pair and every
ordered blind pair's result at once: about 400 kB per FLS at the published
density, 26 GB for a display of 65,536 FLSs. Here the same evaluation runs
in two passes, each a block of FLSs at a time:

1. :func:`lean_neighbourhood`: the neighbour pairs of a block of FLSs (by
   index), their line of sight, then only what paths may use is kept: the
   sweet pairs and the visible decaying pairs (at the published density
   about 1 neighbour pair in 8). The obstructed decaying pairs are counted
   and let go; the blind pairs are kept as ordered rows.
2. :meth:`BlockedEvaluation.blocks`: the ordered blind pairs of a block of
   sources, evaluated by :func:`.evaluate.evaluate_pairs` on the whole
   swarm's graphs, so each pair's path, estimate and errors are the ones
   :func:`.evaluate.evaluate` gives, and the blocks come in its order.

A block's memory is bounded by a :class:`Budget`; the lean neighbourhood
and the blind rows are held whole (about 5 kB and 16 bytes per blind pair,
measured in BENCHMARKS.md, "The engine at display scale").
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .evaluate import Neighbourhood, PairResults, PairTally, Progress, evaluate_pairs, summarise
from .geometry import Swarm
from .neighbours import (
    NeighbourCounts,
    NeighbourPairs,
    candidate_reach,
    neighbour_pairs,
    ordered_rows,
    pair_counts,
)
from .paths import check_policy
from .sensor import BLIND, DECAYING, SWEET, Sensor
from .sight import Grid, build_grid, grid_of, obstructed

IntArray = NDArray[np.int64]

#: Bytes a block holds per ordered blind pair at its peak: paths, hop tables,
#: estimates, errors and the table written from them (measured: the race car).
PAIR_BYTES = 1_200
#: Bytes a block of the neighbourhood holds per candidate pair while its sight is judged.
CANDIDATE_BYTES = 100
#: Real statistics a tally keeps per pair for exact quantiles (PairTally).
REAL_STATISTICS = 7
#: Bytes :func:`.evaluate.evaluate` holds per candidate neighbour pair at its peak,
#: written results included (the race car: 6.8 M pairs, 1.6 GB; torus:10000: 31 M, 4.0 GB).
WHOLE_PAIR_BYTES = 250
#: A block's memory unless the user gives one: pairs of a few million at a time.
DEFAULT_MEMORY = 2 * 2**30


@dataclass(frozen=True)
class Budget:
    """How much memory, bytes, a block of work may hold."""

    memory: int = DEFAULT_MEMORY

    def __post_init__(self) -> None:
        if self.memory < 2**20:
            raise ValueError(f"a block's memory must be at least 1 MiB, got {self.memory} bytes")

    @property
    def block_pairs(self) -> int:
        """Ordered blind pairs a block evaluates, at most (unless one source has more)."""
        return max(1, self.memory // 2 // PAIR_BYTES)

    @property
    def block_candidates(self) -> int:
        """Candidate neighbour pairs a block of the neighbourhood judges, at most."""
        return max(1, self.memory // 2 // CANDIDATE_BYTES)

    @property
    def exact_values(self) -> int:
        """Real values a tally keeps for exact quantiles, per statistic."""
        return max(1, self.memory // 4 // (8 * REAL_STATISTICS))


def ranges(weights: IntArray, limit: int) -> list[tuple[int, int]]:
    """Contiguous index ranges [start, stop) whose ``weights`` (N,) sum to at most ``limit``.

    An item heavier than ``limit`` is a range of its own; no range is empty.
    """
    bounds, start, total = [], 0, 0
    for index, weight in enumerate(np.asarray(weights, dtype=np.int64).tolist()):
        if total + weight > limit and index > start:
            bounds.append((start, index))
            start, total = index, 0
        total += weight
    if start < len(weights):
        bounds.append((start, len(weights)))
    return bounds


@dataclass(frozen=True)
class BlindRows:
    """Every ordered blind pair as CSR rows: source s has targets[rows[s]:rows[s + 1]]."""

    rows: IntArray  # (N + 1,)
    targets: IntArray  # (M,), sorted within each row

    def __len__(self) -> int:
        return len(self.targets)

    def block(self, start: int, stop: int) -> tuple[IntArray, IntArray]:
        """The ordered pairs (source, target) of the sources in [start, stop), sorted."""
        sources = np.repeat(
            np.arange(start, stop, dtype=np.int64), np.diff(self.rows[start : stop + 1])
        )
        return sources, self.targets[self.rows[start] : self.rows[stop]]


def _kept(
    swarm: Swarm, pairs: NeighbourPairs, grid: Grid
) -> tuple[NeighbourPairs, NDArray[np.bool_]]:
    """The pairs paths may use (sweet, and decaying in sight) and their line of sight."""
    sweet = pairs.range_class == SWEET
    edge = sweet | (pairs.range_class == DECAYING)
    visible = np.zeros(len(pairs), dtype=bool)
    visible[edge] = ~obstructed(
        swarm.points, swarm.radius, pairs.first[edge], pairs.second[edge], grid
    )
    keep = sweet | visible
    return pairs.select(keep), visible[keep]


def lean_neighbourhood(
    swarm: Swarm, sensor: Sensor, budget: Budget, progress: Progress
) -> tuple[Neighbourhood, BlindRows]:
    """The swarm's neighbourhood as paths use it, and its ordered blind pairs, block by block.

    The neighbourhood's ``pairs`` hold the sweet pairs and the decaying pairs
    in line of sight, in :func:`.neighbours.neighbour_pairs`'s order; its
    ``counts`` are the whole swarm's.
    """
    reach_grid = grid_of(np.ascontiguousarray(swarm.points), candidate_reach(sensor, swarm.radius))
    sight_grid = build_grid(swarm.points, swarm.radius)
    candidates = pair_counts(swarm, sensor, reach_grid)
    progress.start("neighbours and line of sight", swarm.size)
    parts: list[NeighbourPairs] = []
    visible: list[NDArray[np.bool_]] = []
    blind_first: list[IntArray] = []
    blind_second: list[IntArray] = []
    counts = NeighbourCounts(0, 0, 0)
    for start, stop in ranges(candidates, budget.block_candidates):
        pairs = neighbour_pairs(swarm, sensor, start, stop, reach_grid)
        counts = counts + NeighbourCounts.of(pairs)
        blind = pairs.range_class == BLIND
        blind_first.append(pairs.first[blind])
        blind_second.append(pairs.second[blind])
        kept, seen = _kept(swarm, pairs, sight_grid)
        parts.append(kept)
        visible.append(seen)
        progress.advance(stop - start)
    pairs = NeighbourPairs(
        *(np.concatenate([getattr(part, name) for part in parts]) for name in _PAIR_FIELDS)
    )
    rows, targets = ordered_rows(
        swarm.size, np.concatenate(blind_first), np.concatenate(blind_second)
    )
    hood = Neighbourhood(
        swarm,
        sensor,
        pairs,
        np.concatenate(visible),
        sight_grid,
        np.ones(len(pairs), dtype=bool),
        kept_counts=counts,
    )
    return hood, BlindRows(rows, targets)


_PAIR_FIELDS = ("first", "second", "distance", "tracking", "range_class")


@dataclass
class BlockedEvaluation:
    """A run evaluated block by block: iterate :meth:`blocks`, then read :meth:`summary`."""

    hood: Neighbourhood
    policy: str
    blind: BlindRows
    budget: Budget = field(default_factory=Budget)
    tally: PairTally = field(init=False)
    seconds: float = 0.0  # computing so far: the neighbourhood's and the blocks'

    def __post_init__(self) -> None:
        self.tally = PairTally(self.budget.exact_values)

    def sources(self) -> list[tuple[int, int]]:
        """The blocks: ranges of sources [start, stop), each within the budget's pairs."""
        return ranges(np.diff(self.blind.rows), self.budget.block_pairs)

    def blocks(self, progress: Progress) -> Iterator[PairResults]:
        """Each block's pair results in order, tallied for the summary as they are made."""
        progress.start("pairs", len(self.blind))
        for start, stop in self.sources():
            began = time.perf_counter()
            pairs = evaluate_pairs(self.hood, self.policy, blind=self.blind.block(start, stop))
            self.tally.add(pairs)
            self.seconds += time.perf_counter() - began
            progress.advance(len(pairs))
            yield pairs

    def summary(self) -> dict[str, object]:
        """The run's summary, once every block has been made."""
        if self.tally.pairs != len(self.blind):
            raise RuntimeError("the summary of a blocked evaluation needs every block made first")
        return {**summarise(self.hood, self.policy, self.tally), "seconds": self.seconds}


def evaluate_blocked(
    swarm: Swarm, sensor: Sensor, policy: str, budget: Budget, progress: Progress
) -> BlockedEvaluation:
    """The lean neighbourhood of ``swarm``, ready to evaluate its pairs block by block."""
    check_policy(policy)
    began = time.perf_counter()
    hood, blind = lean_neighbourhood(swarm, sensor, budget, progress)
    return BlockedEvaluation(hood, policy, blind, budget, seconds=time.perf_counter() - began)


def whole_swarm_bytes(swarm: Swarm, sensor: Sensor) -> int:
    """About how much memory :func:`.evaluate.evaluate` of ``swarm`` needs, bytes."""
    return int(pair_counts(swarm, sensor).sum()) * WHOLE_PAIR_BYTES
