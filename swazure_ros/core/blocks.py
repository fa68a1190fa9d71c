"""The engine at display scale: a swarm's pairs evaluated in blocks, in bounded memory.

:func:`.evaluate.evaluate` holds every neighbour pair and every ordered blind
pair's result at once: 1.6 GB for the race car, about 26 GB for a display of
65,536 FLSs. Here the same evaluation runs a block at a time:

1. :func:`lean_neighbourhood`: the neighbour pairs of a run of FLSs (by
   index), counted for the summary; the blind pairs kept as ordered rows,
   the sweet pairs with their line of sight; the rest let go. The decaying
   pairs in sight join at once when the swarm's pairs fit the budget, else
   only when a pair without a sweet path in sight needs them
   (:func:`with_decaying`).
2. :meth:`BlockedEvaluation.blocks`: the ordered blind pairs of a run of
   sources, evaluated by :func:`.evaluate.evaluate_pairs` on the whole
   swarm's graphs, so each pair's path, estimate and errors are the ones
   :func:`.evaluate.evaluate` gives, and the blocks come in its order; the
   summary is tallied block by block (:class:`.pair_statistics.PairTally`).

A block's memory is bounded by a :class:`Budget`; the lean neighbourhood is
held whole (docs/core.md, "The engine at display scale").
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .arrays import BoolArray, IntArray
from .csr import narrowed
from .evaluate import evaluate_pairs
from .evaluation import PairResults
from .fans import obstructed_fans
from .geometry import Swarm
from .grid import Grid, build_grid
from .local_paths import LocalPaths, least_cost_per_cm, local_decaying_paths
from .neighbourhood import Neighbourhood
from .neighbours import (
    FIELDS,
    NeighbourCounts,
    NeighbourPairs,
    neighbour_grid,
    neighbour_pairs,
    ordered_rows,
    pair_counts,
)
from .pair_statistics import PairTally, summarise
from .path_arrays import Paths
from .paths import check_policy
from .progress import Progress, Started
from .sensor import BLIND, DECAYING, SWEET, Sensor
from .sight import obstructed
from .summary import Summary
from .threads import side_by_side

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
#: Bytes a lean neighbourhood holds per pair it keeps (pair record, sight, three graphs):
#: a swarm whose candidate pairs all fit the budget at this price keeps its decaying
#: pairs in sight from the start.
LEAN_PAIR_BYTES = 100
#: A block's memory unless the user gives one: pairs of a few million at a time.
DEFAULT_MEMORY = 2 * 2**30


@dataclass(frozen=True)
class Budget:
    """How much memory, bytes, a block of work may hold; and, for a run that holds every
    pair at once instead (core.pipeline), how much the machine has free (None: unknown,
    not checked)."""

    memory: int = DEFAULT_MEMORY
    free: int | None = None

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
    """Contiguous index ranges [start, stop) whose ``weights`` sum to at most ``limit``.

    Greedy, in index order: the blocks of FLSs or sources a budget allows.

    Parameters
    ----------
    weights : (N,) array of int
        Each item's weight (its pairs), >= 0.
    limit : int
        A range's total weight, at most.

    Returns
    -------
    list of (int, int)
        The ranges, in order, covering 0 .. N; an item heavier than ``limit``
        is a range of its own; no range is empty.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.blocks import ranges
    >>> ranges(np.array([3, 1, 4, 1, 5]), 5)
    [(0, 2), (2, 4), (4, 5)]
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
    """Every ordered blind pair as CSR rows: source s has targets[rows[s]:rows[s + 1]].

    The targets are kept in 32 bits (:func:`.csr.narrowed`): a display's 20 M ordered
    blind pairs are held for the whole run, in 80 MB rather than 160.
    """

    rows: IntArray  # (N + 1,)
    targets: NDArray[np.int32] | IntArray  # (M,), sorted within each row

    @classmethod
    def of(cls, size: int, first: IntArray, second: IntArray) -> BlindRows:
        """The rows of the unordered blind pairs (first, second), each once."""
        rows, targets = ordered_rows(size, first, second)
        return cls(rows, narrowed(targets))

    def __len__(self) -> int:
        return len(self.targets)

    def block(self, start: int, stop: int) -> tuple[IntArray, IntArray]:
        """The ordered pairs (source, target) of the sources in [start, stop), sorted."""
        sources = np.repeat(
            np.arange(start, stop, dtype=np.int64), np.diff(self.rows[start : stop + 1])
        )
        targets = self.targets[self.rows[start] : self.rows[stop]]
        return sources, targets.astype(np.int64, copy=False)


def _in_sight(
    swarm: Swarm, pairs: NeighbourPairs, range_class: int, grid: Grid, fans: bool = False
) -> tuple[NeighbourPairs, NDArray[np.bool_]]:
    """The pairs of one range class, and whether each is in line of sight; with ``fans``,
    judged a first FLS at a time (:mod:`.fans`: the same judgements)."""
    chosen = pairs.select(pairs.range_class == range_class)
    if fans:
        visible = ~obstructed_fans(
            swarm.points, swarm.radius, chosen.first, chosen.second, grid=grid
        )
    else:
        visible = ~obstructed(swarm.points, swarm.radius, chosen.first, chosen.second, grid)
    return chosen, visible


@dataclass(frozen=True)
class LeanNeighbourhood:
    """A swarm's neighbourhood as its paths use it, found and kept a block of FLSs at a time.

    ``sweet`` holds the sweet pairs only: enough for every pair whose sweet
    path is in sight (on a surface such as a torus or a sphere, every pair).
    ``whole`` adds the decaying pairs in sight, which the pairs without such
    a path search; it is built at once when the swarm's candidate pairs fit
    the budget, else by :func:`with_decaying` when a block first needs it
    (their line of sight, 9 in 10 of the work, is then judged only if used).
    Both hold the whole swarm's counts.
    """

    swarm: Swarm
    sensor: Sensor
    budget: Budget
    blocks: list[tuple[int, int]]  # ranges of FLSs [start, stop) whose pairs a block finds
    sweet: Neighbourhood
    blind: BlindRows
    candidates: IntArray  # (N,), each FLS's candidate pairs as first (neighbours.pair_counts)
    whole: Neighbourhood | None


def lean_neighbourhood(
    swarm: Swarm, sensor: Sensor, budget: Budget, progress: Progress
) -> LeanNeighbourhood:
    """The swarm's :class:`LeanNeighbourhood` and its ordered blind pairs, block by block.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    budget : Budget
        Bytes a block may hold; also decides whether the decaying pairs in
        sight are kept at once (the swarm's candidate pairs fit it).
    progress : Progress
        Told of the stage "neighbours and line of sight", in candidate pairs.

    Returns
    -------
    LeanNeighbourhood
        ``whole`` None when the decaying pairs are left for
        :func:`with_decaying`.
    """
    reach_grid = neighbour_grid(swarm, sensor)
    sight_grid = build_grid(swarm.points, swarm.radius)
    candidates = pair_counts(swarm, sensor, reach_grid)
    blocks = ranges(candidates, budget.block_candidates)
    at_once = int(candidates.sum()) * LEAN_PAIR_BYTES <= budget.memory
    progress.start("neighbours and line of sight", int(candidates.sum()))
    # Pieces by field, each let go once joined: the pairs are held about once, not twice.
    sweet: dict[str, list[NDArray[Any]]] = {name: [] for name in FIELDS}
    sweet_sight: list[NDArray[np.bool_]] = []
    seen: dict[str, list[NDArray[Any]]] = {name: [] for name in FIELDS}
    blind_first: list[IntArray] = []
    blind_second: list[IntArray] = []
    counts = NeighbourCounts(0, 0, 0)
    found = partial(_block_pairs, swarm, sensor, reach_grid, sight_grid, at_once)
    for (start, stop), block in zip(blocks, side_by_side(found, blocks, BLOCKS_AT_ONCE, "block")):
        counts = counts + block.counts
        blind_first.append(block.blind_first)
        blind_second.append(block.blind_second)
        _keep(sweet, block.sweet)
        sweet_sight.append(block.sweet_visible)
        if block.decaying is not None:
            _keep(seen, *block.decaying)
        progress.advance(int(candidates[start:stop].sum()))
    first = np.concatenate(blind_first)
    blind_first.clear()
    second = np.concatenate(blind_second)
    blind_second.clear()
    blind = BlindRows.of(swarm.size, first, second)
    del first, second
    sweet_pairs = NeighbourPairs.from_pieces(sweet)
    sweet_hood = Neighbourhood(
        swarm, sensor, sweet_pairs, np.concatenate(sweet_sight), sight_grid,
        np.ones(len(sweet_pairs), dtype=bool), kept_counts=counts,
    )  # fmt: skip
    lean = LeanNeighbourhood(swarm, sensor, budget, blocks, sweet_hood, blind, candidates, None)
    return replace(lean, whole=_whole(lean, seen)) if at_once else lean


#: Blocks of FLSs whose pairs are found and judged at once, each on a thread of its own:
#: between its compiled kernels a block's numpy work leaves a core idle, which the next
#: block fills. Taken in order, so the neighbourhood is the same with one at a time.
BLOCKS_AT_ONCE = 2


class _BlockPairs(NamedTuple):
    """What :func:`lean_neighbourhood` keeps of a block of FLSs' candidate pairs."""

    counts: NeighbourCounts
    blind_first: IntArray
    blind_second: IntArray
    sweet: NeighbourPairs
    sweet_visible: BoolArray
    decaying: tuple[NeighbourPairs, BoolArray] | None  # with their sight, where kept


def _block_pairs(
    swarm: Swarm,
    sensor: Sensor,
    reach_grid: Grid,
    sight_grid: Grid,
    with_decaying: bool,
    block: tuple[int, int],
) -> _BlockPairs:
    """The pairs of the FLSs ``block`` (start, stop) as first, sorted into what is kept."""
    pairs = neighbour_pairs(swarm, sensor, *block, reach_grid)
    blind = pairs.range_class == BLIND
    sweet, visible = _in_sight(swarm, pairs, SWEET, sight_grid)
    decaying = _in_sight(swarm, pairs, DECAYING, sight_grid) if with_decaying else None
    counts = NeighbourCounts.of(pairs)
    return _BlockPairs(counts, pairs.first[blind], pairs.second[blind], sweet, visible, decaying)


def _keep(
    seen: dict[str, list[NDArray[Any]]], pairs: NeighbourPairs, visible: BoolArray | None = None
) -> None:
    """Add the ``pairs`` (those in sight, given ``visible``) to ``seen``, field by field."""
    kept = slice(None) if visible is None else np.flatnonzero(visible)
    for name in FIELDS:
        seen[name].append(getattr(pairs, name)[kept])


def _whole(lean: LeanNeighbourhood, seen: dict[str, list[NDArray[Any]]]) -> Neighbourhood:
    """``lean.sweet`` with the decaying pairs in sight joined to its pairs, in order.

    ``seen`` holds their fields in pieces (:meth:`.NeighbourPairs.merged`), and is
    emptied; the sweet neighbourhood's own graphs are let go, since the whole one
    builds its own over the same pairs.
    """
    sweet = lean.sweet
    pairs, decaying = sweet.pairs.merged(seen, lean.swarm.size)
    visible = np.ones(len(pairs), dtype=bool)
    visible[~decaying] = sweet.visible
    sweet.forget_graphs()
    return replace(sweet, pairs=pairs, visible=visible, usable=np.ones(len(pairs), dtype=bool))


def with_decaying(lean: LeanNeighbourhood, progress: Progress) -> LeanNeighbourhood:
    """``lean`` with its ``whole`` neighbourhood: the decaying pairs in sight, block by block.

    Parameters
    ----------
    lean : LeanNeighbourhood
    progress : Progress
        Told of the stage "decaying pairs in line of sight".

    Returns
    -------
    LeanNeighbourhood
        ``lean`` itself when it has its ``whole`` already.
    """
    if lean.whole is not None:
        return lean
    swarm, sensor = lean.swarm, lean.sensor
    reach_grid = neighbour_grid(swarm, sensor)
    progress.start("decaying pairs in line of sight", lean.sweet.counts.decaying)
    seen: dict[str, list[NDArray[Any]]] = {name: [] for name in FIELDS}
    for start, stop in lean.blocks:
        pairs = neighbour_pairs(swarm, sensor, start, stop, reach_grid)
        # Thousands of long segments from each FLS, few blocked close to it: judged by fans
        # (BENCHMARKS.md, "Line of sight by fans").
        part, visible = _in_sight(swarm, pairs, DECAYING, lean.sweet.grid, fans=True)
        _keep(seen, part, visible)
        progress.advance(len(part))
    return replace(lean, whole=_whole(lean, seen))


def _apart_in_sight(hood: Neighbourhood, source: IntArray, target: IntArray) -> BoolArray:
    """Which pairs (source[m], target[m]) have no sweet path in sight: their ends lie in two
    parts of S_vis. Known from the parts alone, before any search of the block."""
    components = hood.sweet_visible_components
    return np.asarray(components[source] != components[target])


@dataclass
class NearDecaying:
    """The SD_vis paths of a run's pairs without a sweet path in sight, searched near them
    (:mod:`.local_paths`) once for the run and handed to its blocks in order."""

    hood: Neighbourhood  # the sweet pairs, and the decaying pairs the paths hop over
    found: LocalPaths
    taken: int = 0  # the paths handed out so far

    def next(self, count: int) -> Paths:
        """The next ``count`` pairs' paths: a block's pairs without a sweet path in sight."""
        low, self.taken = self.taken, self.taken + count
        return self.found.paths.span(low, self.taken)


def _near_decaying(
    lean: LeanNeighbourhood, policy: str, sources: list[tuple[int, int]], progress: Progress
) -> NearDecaying:
    """The SD_vis paths of every ordered blind pair without a sweet path in sight, searched
    near each pair in regions of ``lean.budget``'s candidate pairs; the sweet neighbourhood
    joined by the decaying pairs they hop over (its own graphs let go)."""
    source, target = [], []
    for start, stop in sources:
        block_source, block_target = lean.blind.block(start, stop)
        apart = _apart_in_sight(lean.sweet, block_source, block_target)
        source.append(block_source[apart])
        target.append(block_target[apart])
    found = local_decaying_paths(
        lean.sweet, policy, np.concatenate(source), np.concatenate(target), lean.candidates,
        lean.budget.block_candidates, progress,
    )  # fmt: skip
    seen = {name: [getattr(found.hopped, name)] for name in FIELDS}
    return NearDecaying(_whole(lean, seen), found)


@dataclass
class BlockedEvaluation:
    """A run evaluated block by block: iterate :meth:`blocks`, then read :meth:`summary`."""

    lean: LeanNeighbourhood
    policy: str
    seconds: float = 0.0  # computing so far: the neighbourhood's and the blocks'
    # Search the decaying paths near their pairs when the decaying pairs are not held: for
    # plain Swazure or a heuristic, which read no decaying pair but those the paths hop over.
    near_pairs: bool = False
    # A later stage made per block (fusion, a fit: core.pipeline), before the tally; it may
    # show stages of its own on the progress it is lent.
    stage: Callable[[Neighbourhood, PairResults, Progress], PairResults] | None = None
    tally: PairTally = field(init=False)
    near: NearDecaying | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        self.tally = PairTally(self.lean.budget.exact_values)

    @property
    def hood(self) -> Neighbourhood:
        """The neighbourhood the blocks search now (its swarm, sensor and counts are the run's)."""
        if self.lean.whole is None and self.near is not None:
            return self.near.hood
        return self.lean.whole or self.lean.sweet

    def sources(self) -> list[tuple[int, int]]:
        """The blocks: ranges of sources [start, stop), each within the budget's pairs."""
        return ranges(np.diff(self.lean.blind.rows), self.lean.budget.block_pairs)

    def blocks(self, progress: Progress) -> Iterator[PairResults]:
        """Each block's pair results in order, tallied for the summary as they are made."""
        total, done = len(self.lean.blind), 0
        progress.start("pairs", total)
        for start, stop in self.sources():
            began = time.perf_counter()
            blind = self.lean.blind.block(start, stop)
            decaying = None
            if self.lean.whole is None:
                apart = _apart_in_sight(self.hood, *blind)
                if self.near is None and apart.any():
                    # A pair without a sweet path in sight searches the decaying pairs too:
                    # near each such pair, or in SD_vis held whole.
                    if self.near_pairs:
                        self.near = _near_decaying(
                            self.lean, self.policy, self.sources(), progress
                        )
                    else:
                        self.lean = with_decaying(self.lean, progress)
                    progress.start("pairs", total)
                    progress.advance(done)
                if self.near is not None:
                    decaying = self.near.next(int(apart.sum()))
            pairs = evaluate_pairs(self.hood, self.policy, blind=blind, decaying=decaying)
            if self.stage is not None:
                lent = Started(progress)
                pairs = self.stage(self.hood, pairs, lent)
                if lent.started:
                    # The stage showed stages of its own (a fit solved for its first block).
                    progress.start("pairs", total)
                    progress.advance(done)
            self.tally.add(pairs)
            self.seconds += time.perf_counter() - began
            done += len(pairs)
            progress.advance(len(pairs))
            yield pairs

    def summary(self) -> Summary:
        """The run's summary, once every block has been made."""
        if self.tally.pairs != len(self.lean.blind):
            raise RuntimeError("the summary of a blocked evaluation needs every block made first")
        return summarise(self.hood, self.policy, self.tally, self.seconds)


def evaluate_blocked(
    swarm: Swarm,
    sensor: Sensor,
    policy: str,
    budget: Budget,
    progress: Progress,
    near_pairs: bool = False,
) -> BlockedEvaluation:
    """The lean neighbourhood of ``swarm``, ready to evaluate its pairs block by block.

    Each block's pairs are those :func:`.evaluate.evaluate` gives, in its
    order; the summary is tallied as the blocks are made.

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor
    policy : {'fewest-hops', 'shortest-length', 'least-error'}
    budget : Budget
        Bytes a block may hold, at least 1 MiB.
    progress : Progress
        Told of each stage (``evaluate.SILENT`` shows nothing).
    near_pairs : bool, default False
        Search the decaying paths near their pairs (:mod:`.local_paths`), not
        in SD_vis held whole, where the swarm's decaying pairs do not fit the
        budget at once (the fewest-hops and shortest-length policies): the
        same pairs, for a run whose later stages (a heuristic) read no other
        decaying pair.

    Returns
    -------
    BlockedEvaluation
        Iterate its ``blocks(progress)``, then read its ``summary()``.

    Raises
    ------
    ValueError
        An unknown policy.

    Examples
    --------
    >>> from swazure_ros.core.blocks import Budget, evaluate_blocked
    >>> from swazure_ros.core.clouds import builtin_points
    >>> from swazure_ros.core.progress import SILENT
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(builtin_points("torus:120") * 5, beta=0.5)
    >>> run = evaluate_blocked(swarm, published, "shortest-length", Budget(2**20), SILENT)
    >>> sum(len(block) for block in run.blocks(SILENT)), run.summary().pairs.blind_pairs
    (3378, 3378)
    """
    check_policy(policy)
    began = time.perf_counter()
    lean = lean_neighbourhood(swarm, sensor, budget, progress)
    # Least-error's costs have no bound per cm: its decaying paths are searched held whole.
    near_pairs = near_pairs and least_cost_per_cm(sensor, swarm.radius, policy) > 0.0
    return BlockedEvaluation(
        lean, policy, seconds=time.perf_counter() - began, near_pairs=near_pairs
    )


def whole_swarm_bytes(swarm: Swarm, sensor: Sensor) -> int:
    """About how much memory :func:`.evaluate.evaluate` of ``swarm`` needs, bytes.

    A counting pass of the neighbour kernel: ``WHOLE_PAIR_BYTES`` per
    candidate pair (measured on the race car and torus:10000).

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor

    Returns
    -------
    int, bytes
    """
    return int(pair_counts(swarm, sensor).sum()) * WHOLE_PAIR_BYTES
