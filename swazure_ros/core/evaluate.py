"""The batch evaluation: every ordered blind pair of a swarm, its status, path and errors.

:func:`neighbourhood` computes what the whole swarm shares (neighbour pairs,
line of sight, the neighbour graphs); :func:`evaluate_pairs` applies section 5
of the spec to every ordered blind pair; :func:`summarise` reduces the pairs
to the run's metrics (section 6); :func:`evaluate` does all three.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from .. import __version__
from . import csr, jit
from .arrays import FloatArray, IntArray
from .geometry import Swarm
from .graph import Graph, make_graph
from .metrics import NO_VALUES, Stats, pose_errors
from .neighbours import (
    NeighbourCounts,
    NeighbourPairs,
    neighbour_pairs,
    ordered_blind_pairs,
    pairs_of,
)
from .path_arrays import Paths, merge_paths, path_hops
from .paths import check_policy, shortest_paths
from .sensor import DECAYING, SWEET, Sensor, expected_error, hop_error, measured_vectors
from .sight import Grid, build_grid, obstructed, obstructers, segments_near
from .summary import FitFacts, FusionFacts, HeuristicFacts, PairStatistics, Parameters, Summary
from .tally import IntegerTally, RealTally

if TYPE_CHECKING:
    from scipy.spatial import cKDTree


# Statuses and reasons; the values equal the constants of swazure_interfaces/PoseEstimate.
SWEET_PATH, DECAYING_PATH, NO_PATH = 0, 1, 2
#: A distributed run that ended before its result (never from the engine).
ABORTED = 3
STATUS_NAMES = ("SWEET", "DECAYING", "NO_PATH", "ABORTED")
REASON_NONE, REASON_BLOCKED, REASON_NO_SWEET_PATH = 0, 1, 2
#: Why a distributed run was ABORTED: its coordinator left the graph mid-run.
REASON_COORDINATOR_LOST = 3
REASON_NAMES = ("", "BLOCKED", "NO_SWEET_PATH", "COORDINATOR_LOST")


class Progress(Protocol):
    """Receives progress of long stages: ``start`` a stage of ``total`` units, then ``advance``."""

    def start(self, stage: str, total: int) -> None: ...

    def advance(self, units: int) -> None: ...


class _Silent:
    def start(self, stage: str, total: int) -> None:
        pass

    def advance(self, units: int) -> None:
        pass


#: Progress that shows nothing.
SILENT: Progress = _Silent()


@dataclass(frozen=True)
class Neighbourhood:
    """What every pair evaluation of one swarm shares: pairs, line of sight, graphs.

    The graphs are built when first used: a simulated world that only senses
    (a revision of a heuristic's moves) never needs them.
    """

    swarm: Swarm
    sensor: Sensor
    pairs: NeighbourPairs  # unordered pairs within reach, sorted
    visible: NDArray[np.bool_]  # (len(pairs),), line of sight (False for blind pairs)
    grid: Grid
    usable: NDArray[np.bool_]  # (len(pairs),), pairs the graphs may hold (see without())
    # The whole swarm's counts when ``pairs`` holds only the pairs paths may use (core.blocks).
    kept_counts: NeighbourCounts | None = None

    @property
    def counts(self) -> NeighbourCounts:
        """How many neighbour pairs of each kind the swarm has."""
        return self.kept_counts or NeighbourCounts.of(self.pairs)

    @cached_property
    def sweet_components(self) -> IntArray:
        """Connected-component label of every FLS in S_all: (N,)."""
        return self.sweet_all.components()

    def _graph(self, mask: NDArray[np.bool_]) -> Graph:
        index = np.flatnonzero(mask & self.usable)
        pairs = self.pairs
        tracking = pairs.tracking[index]
        costs = hop_error(self.sensor, tracking, self.swarm.radius)
        return make_graph(
            self.swarm.size, pairs.first[index], pairs.second[index], tracking, index, costs
        )

    @cached_property
    def sweet_all(self) -> Graph:
        """S_all: sweet pairs, line of sight ignored."""
        return self._graph(self.pairs.range_class == SWEET)

    @cached_property
    def sweet_visible(self) -> Graph:
        """S_vis: sweet pairs in line of sight."""
        return self._graph((self.pairs.range_class == SWEET) & self.visible)

    @cached_property
    def any_visible(self) -> Graph:
        """SD_vis: sweet or decaying pairs in line of sight."""
        reach = (self.pairs.range_class == SWEET) | (self.pairs.range_class == DECAYING)
        return self._graph(reach & self.visible)


def neighbourhood(swarm: Swarm, sensor: Sensor, progress: Progress | None = None) -> Neighbourhood:
    """Neighbour pairs, their line of sight, and the graphs S_all, S_vis and SD_vis."""
    progress = progress or SILENT
    pairs = neighbour_pairs(swarm, sensor)
    edge = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    grid = build_grid(swarm.points, swarm.radius)
    progress.start("line of sight", int(edge.sum()))
    visible = np.zeros(len(pairs), dtype=bool)
    visible[edge] = ~obstructed(
        swarm.points, swarm.radius, pairs.first[edge], pairs.second[edge], grid
    )
    progress.advance(int(edge.sum()))
    return Neighbourhood(swarm, sensor, pairs, visible, grid, np.ones(len(pairs), dtype=bool))


def neighbourhood_of(
    swarm: Swarm,
    sensor: Sensor,
    flss: IntArray,
    grid: Grid | None = None,
    tree: cKDTree | None = None,
) -> Neighbourhood:
    """The pairs that involve the FLSs at indices ``flss`` (K,), with their line of sight.

    Each of these FLSs' pairs equal those of ``neighbourhood(swarm, sensor)``;
    the pairs between other FLSs are left out. ``grid`` (``build_grid``'s)
    and ``tree`` (a cKDTree of the points) are the swarm's, when the caller
    keeps them.
    """
    flss = np.unique(np.asarray(flss, dtype=np.int64))
    pairs = pairs_of(swarm, sensor, flss, tree)
    edge = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    grid = grid or build_grid(swarm.points, swarm.radius)
    visible = np.zeros(len(pairs), dtype=bool)
    visible[edge] = ~obstructed(
        swarm.points, swarm.radius, pairs.first[edge], pairs.second[edge], grid
    )
    return Neighbourhood(swarm, sensor, pairs, visible, grid, np.ones(len(pairs), dtype=bool))


def moved_neighbourhood(hood: Neighbourhood, swarm: Swarm, moved: IntArray) -> Neighbourhood:
    """``hood`` of ``swarm``, where only the FLSs at indices ``moved`` (K,) have new positions.

    Equal to ``neighbourhood(swarm, hood.sensor)`` at a cost in proportion to
    what moved: the pairs of the moved FLSs are found anew, and line of sight
    is judged again only for those pairs and for the segments that pass
    within r of a moved FLS's old or new place (an FLS obstructs a segment
    within r of its centre); every other pair keeps its line of sight.
    """
    moved = np.unique(np.asarray(moved, dtype=np.int64))
    sensor, old = hood.sensor, hood.pairs
    if len(moved) == 0:
        return hood
    involved = np.isin(old.first, moved) | np.isin(old.second, moved)
    kept = old.select(~involved)
    fresh = pairs_of(swarm, sensor, moved)
    first = np.concatenate([kept.first, fresh.first])
    second = np.concatenate([kept.second, fresh.second])
    order = np.argsort(first * swarm.size + second)  # unique keys: faster than lexsort
    pairs = NeighbourPairs(
        first[order],
        second[order],
        np.concatenate([kept.distance, fresh.distance])[order],
        np.concatenate([kept.tracking, fresh.tracking])[order],
        np.concatenate([kept.range_class, fresh.range_class])[order],
    )
    visible = np.concatenate([hood.visible[~involved], np.zeros(len(fresh), dtype=bool)])[order]
    edge = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    anew = np.isin(pairs.first, moved) | np.isin(pairs.second, moved)
    places = np.concatenate([hood.swarm.points[moved], swarm.points[moved]])
    passing = edge & ~anew
    # Twice r: a margin over the obstruction distance, so that no rounding in the
    # two distance computations can leave out a segment whose sight changed.
    passing[passing] = segments_near(
        swarm.points, pairs.first[passing], pairs.second[passing], places, 2.0 * swarm.radius
    )
    judge = edge & (anew | passing)
    grid = build_grid(swarm.points, swarm.radius)
    visible[judge] = ~obstructed(
        swarm.points, swarm.radius, pairs.first[judge], pairs.second[judge], grid
    )
    return Neighbourhood(swarm, sensor, pairs, visible, grid, np.ones(len(pairs), dtype=bool))


def without(hood: Neighbourhood, gone: IntArray) -> Neighbourhood:
    """``hood`` with no path through the FLSs at indices ``gone`` (K,); their bodies still block.

    What the swarm offers once these FLSs stop answering: line of sight is
    unchanged, since a stopped FLS has not left its place.
    """
    pairs = hood.pairs
    usable = ~(np.isin(pairs.first, gone) | np.isin(pairs.second, gone))
    return replace(hood, usable=usable)


@dataclass(frozen=True)
class PairResults:
    """Per ordered blind pair (M of them): status, path and errors. Indices are swarm indices."""

    source: IntArray  # (M,)
    target: IntArray  # (M,)
    status: NDArray[np.int8]  # SWEET_PATH, DECAYING_PATH, NO_PATH
    reason: NDArray[np.int8]  # REASON_NONE, REASON_BLOCKED, REASON_NO_SWEET_PATH
    hops: IntArray
    sweet_hops: IntArray
    decaying_hops: IntArray
    path_length: FloatArray  # sum of hop tracking distances, cm; nan without a path
    offsets: IntArray  # (M + 1,): path m is nodes[offsets[m]:offsets[m + 1]]
    nodes: IntArray
    estimate: FloatArray  # (M, 3), cm; nan without a path
    truth: FloatArray  # (M, 3), cm
    distance_error: FloatArray  # percent; nan without a path
    alpha: FloatArray  # degrees
    theta: FloatArray  # degrees
    phi: FloatArray  # degrees
    sweet_connected: NDArray[np.bool_]  # an S_all path exists
    sweet_obstructed: NDArray[np.bool_]  # the policy's S_all path has an obstructed hop
    obstructing_flss: IntArray  # distinct obstructing FLSs on that path
    # Predicted error of the estimate, cm (core.sensor.expected_error); nan if unknown.
    predicted_error: FloatArray
    fused_paths: IntArray  # paths the estimate combines: 1, more when fused, 0 without a path
    # (M, 3, 3), cm^2: the estimate's covariance, where the estimator gives one (core.fit).
    covariance: FloatArray | None = None

    def __len__(self) -> int:
        return len(self.source)

    def path(self, pair: int) -> list[int]:
        """Swarm indices of the path of pair ``pair``; [] when it has none."""
        return [int(node) for node in self.nodes[self.offsets[pair] : self.offsets[pair + 1]]]

    def with_estimates(self, estimate: FloatArray, **changes: Any) -> PairResults:
        """These pairs with other estimates (M, 3), cm, and the errors that follow from them."""
        distance_error, alpha, theta, phi = pose_errors(estimate, self.truth)
        return replace(
            self,
            estimate=estimate,
            distance_error=distance_error,
            alpha=alpha,
            theta=theta,
            phi=phi,
            **changes,
        )


@dataclass(frozen=True)
class Evaluation:
    """One run: a swarm, a sensor, a policy, every ordered blind pair and the summary."""

    hood: Neighbourhood
    policy: str
    pairs: PairResults
    summary: Summary


@dataclass(frozen=True)
class HopTable:
    """Every hop of M paths, in path order: which path, its ends, and the pair it crosses."""

    size: int  # M, the number of paths
    path: IntArray  # (H,), the path of each hop
    start: IntArray  # (H,), FLS the hop leaves
    end: IntArray  # (H,), FLS the hop reaches
    pair: IntArray  # (H,), index of the hop's pair in the neighbourhood's ``pairs``
    slot: IntArray  # (H,), the hop's edge start -> end in SD_vis (CSR position); -1 if none

    def sums(self, values: FloatArray) -> FloatArray:
        """Sum over each path's hops of ``values`` (H,): (M,), summed from the source outwards."""
        # bincount adds in array order, and the hops of a path are listed in order.
        return np.bincount(self.path, weights=values, minlength=self.size).astype(np.float64)


def hop_table(hood: Neighbourhood, paths: Paths) -> HopTable:
    """The hops of ``paths``, each with its pair in ``hood.pairs``."""
    path, start, end = path_hops(paths)
    # Nearly every hop is an edge of SD_vis, whose rows are shorter than those of all pairs.
    graph = hood.any_visible
    slot = graph.edge_positions(start, end)
    pair = np.full(len(slot), -1, dtype=np.int64)
    pair[slot >= 0] = graph.labels[slot[slot >= 0]]
    elsewhere = slot < 0
    if elsewhere.any():
        pair[elsewhere] = hood.pairs.index(start[elsewhere], end[elsewhere])
    if np.any(pair < 0):
        raise ValueError("a path hops between FLSs out of each other's reach")
    return HopTable(len(paths.found), path, start, end, pair, slot)


def hop_vectors(hood: Neighbourhood, hops: HopTable) -> tuple[FloatArray, IntArray]:
    """Measured vectors (K, 3), cm, and the row of each hop (H,) among them.

    Each directed edge of SD_vis is measured once, however many paths cross it.
    """
    swarm, sensor, graph = hood.swarm, hood.sensor, hood.any_visible
    on_graph = hops.slot >= 0
    # A pair's two directions are two measurements (a noisy sensor draws per direction).
    measured = np.zeros(len(graph.indices), dtype=bool)
    measured[hops.slot[on_graph]] = True
    slots = np.flatnonzero(measured)
    row_of_slot = np.zeros(len(measured), dtype=np.int64)
    row_of_slot[slots] = np.arange(len(slots))
    leaves = csr.run_of(graph.indptr)[slots]
    once = measured_vectors(sensor, swarm.points, swarm.radius, leaves, graph.indices[slots])
    if on_graph.all():
        return once, row_of_slot[hops.slot]
    off = np.flatnonzero(~on_graph)
    rows = np.empty(len(hops.slot), dtype=np.int64)
    rows[on_graph] = row_of_slot[hops.slot[on_graph]]
    rows[off] = len(once) + np.arange(len(off))
    others = measured_vectors(sensor, swarm.points, swarm.radius, hops.start[off], hops.end[off])
    return np.concatenate([once, others]), rows


@jit.kernel(cache=True, parallel=True)
def _path_vector_sums(hop_offsets: IntArray, rows: IntArray, vectors: FloatArray) -> FloatArray:
    """Sum of vectors[rows[h]] over the hops h of each path, from the source outwards: (M, 3)."""
    out = np.zeros((len(hop_offsets) - 1, 3))
    for path in jit.prange(len(hop_offsets) - 1):
        x, y, z = 0.0, 0.0, 0.0
        for hop in range(hop_offsets[path], hop_offsets[path + 1]):
            x += vectors[rows[hop], 0]
            y += vectors[rows[hop], 1]
            z += vectors[rows[hop], 2]
        out[path, 0], out[path, 1], out[path, 2] = x, y, z
    return out


def estimates(
    hood: Neighbourhood, paths: Paths, hops: HopTable | None = None
) -> tuple[FloatArray, IntArray, IntArray]:
    """Summed measured hop vectors of each path (M, 3), cm, and its sweet and decaying hops.

    ``hops``: ``hop_table(hood, paths)``, when the caller has it.
    """
    hops = hops or hop_table(hood, paths)
    vectors, rows = hop_vectors(hood, hops)
    hop_offsets = csr.offsets(np.bincount(hops.path, minlength=hops.size))
    estimate = np.asarray(_path_vector_sums(hop_offsets, rows, vectors))
    estimate[~paths.found] = np.nan
    sweet_hops, decaying_hops = hop_classes(hood, paths, hops)
    return estimate, sweet_hops, decaying_hops


def summed_hop_errors(
    hood: Neighbourhood, paths: Paths, hops: HopTable | None = None
) -> FloatArray:
    """Sum of :func:`~.sensor.hop_error` over each path's hops: (M,); nan without a path."""
    hops = hops or hop_table(hood, paths)
    costs = hop_error(hood.sensor, hood.pairs.tracking[hops.pair], hood.swarm.radius)
    return np.where(paths.found, hops.sums(costs), np.nan)


def hop_classes(
    hood: Neighbourhood, paths: Paths, hops: HopTable | None = None
) -> tuple[IntArray, IntArray]:
    """Sweet and decaying hops of each path: (M,) each."""
    hops = hops or hop_table(hood, paths)
    size = len(paths.found)
    hop_class = hood.pairs.range_class[hops.pair]
    sweet_hops = np.bincount(hops.path[hop_class == SWEET], minlength=size)
    decaying_hops = np.bincount(hops.path[hop_class == DECAYING], minlength=size)
    return sweet_hops.astype(np.int64), decaying_hops.astype(np.int64)


@jit.kernel(cache=True, parallel=True)
def _distinct_per_path(
    hop_offsets: IntArray, hop_edge: IntArray, edge_offsets: IntArray, edge_ids: IntArray
) -> IntArray:
    """Distinct obstructer ids over the hops of each path; hop_edge is -1 for a clear hop."""
    paths = len(hop_offsets) - 1
    out = np.zeros(paths, dtype=np.int64)
    for path in jit.prange(paths):
        total = 0
        for hop in range(hop_offsets[path], hop_offsets[path + 1]):
            if hop_edge[hop] >= 0:
                total += edge_offsets[hop_edge[hop] + 1] - edge_offsets[hop_edge[hop]]
        if total == 0:
            continue
        gathered = np.empty(total, dtype=np.int64)
        filled = 0
        for hop in range(hop_offsets[path], hop_offsets[path + 1]):
            edge = hop_edge[hop]
            if edge >= 0:
                count = edge_offsets[edge + 1] - edge_offsets[edge]
                gathered[filled : filled + count] = edge_ids[
                    edge_offsets[edge] : edge_offsets[edge + 1]
                ]
                filled += count
        gathered.sort()
        distinct = 1
        for slot in range(1, total):
            if gathered[slot] != gathered[slot - 1]:
                distinct += 1
        out[path] = distinct
    return out


def path_obstruction(
    hood: Neighbourhood, graph: Graph, paths: Paths
) -> tuple[NDArray[np.bool_], IntArray]:
    """Whether each path in ``graph`` has an obstructed hop, and its distinct obstructing FLSs."""
    size = len(paths.found)
    pair, start, end = path_hops(paths)
    hop_pair = graph.edge_labels(start, end)
    blocked = ~hood.visible[hop_pair]
    has_obstruction = np.bincount(pair[blocked], minlength=size) > 0
    # Each blocked pair's obstructers are found once, however many paths cross it.
    crossed = np.zeros(len(hood.pairs), dtype=bool)
    crossed[hop_pair[blocked]] = True
    edges = np.flatnonzero(crossed)
    edge_number = np.zeros(len(crossed), dtype=np.int64)
    edge_number[edges] = np.arange(len(edges))
    edge_of_blocked_hop = edge_number[hop_pair[blocked]]
    swarm = hood.swarm
    offsets, ids = obstructers(
        swarm.points, swarm.radius, hood.pairs.first[edges], hood.pairs.second[edges], hood.grid
    )
    hop_edge = np.full(len(pair), -1, dtype=np.int64)
    hop_edge[blocked] = edge_of_blocked_hop
    hop_offsets = csr.offsets(np.bincount(pair, minlength=size))
    distinct = _distinct_per_path(hop_offsets.astype(np.int64), hop_edge, offsets, ids)
    return has_obstruction, np.asarray(distinct)


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


def _pct(part: int, whole: int) -> float:
    return 100.0 * part / whole if whole else 0.0


#: Real values a tally keeps for exact quantiles by default: the published shapes'
#: pairs (2.07 M at most) and more; a bounded run sets its own (core.blocks).
EXACT_VALUES = 50_000_000


@dataclass
class PairTally:
    """The summary's per-pair statistics, gathered from one block of pairs at a time."""

    exact_values: int = EXACT_VALUES
    pairs: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    reals: dict[str, RealTally] = field(default_factory=dict)
    integers: dict[str, IntegerTally] = field(default_factory=dict)
    known_predictions: int = 0  # pairs with a path and a predicted error
    within_predicted: int = 0  # of those, the pairs whose error is within it

    def _count(self, name: str, mask: NDArray[np.bool_]) -> None:
        self.counts[name] = self.counts.get(name, 0) + int(np.count_nonzero(mask))

    def _real(self, name: str, values: FloatArray) -> None:
        self.reals.setdefault(name, RealTally(self.exact_values)).add(values)

    def _integer(self, name: str, values: IntArray) -> None:
        self.integers.setdefault(name, IntegerTally()).add(values)

    def add(self, pairs: PairResults) -> None:
        """Gather the statistics of ``pairs``, a block of the run's."""
        self.pairs += len(pairs)
        has_path = pairs.status != NO_PATH
        # A pair a heuristic resolved has no predicted error: the mean is of those with one.
        known = np.isfinite(pairs.predicted_error) & has_path
        sweet, decaying = pairs.status == SWEET_PATH, pairs.status == DECAYING_PATH
        obstructed_paths = pairs.sweet_obstructed & pairs.sweet_connected
        for name, mask in (
            ("sweet", sweet),
            ("decaying", decaying),
            ("no_path", ~has_path),
            ("blocked", pairs.reason == REASON_BLOCKED),
            ("no_sweet_path", pairs.reason == REASON_NO_SWEET_PATH),
            ("sweet_connected", pairs.sweet_connected),
            ("obstructed", obstructed_paths),
        ):
            self._count(name, mask)
        for name, values in (
            ("distance_error_pct", pairs.distance_error[has_path]),
            ("distance_error_pct_sweet_paths", pairs.distance_error[sweet]),
            ("distance_error_pct_decaying_paths", pairs.distance_error[decaying]),
            ("alpha_deg", pairs.alpha[has_path]),
            ("theta_deg", pairs.theta[has_path]),
            ("phi_deg", pairs.phi[has_path]),
            ("predicted_error_cm", pairs.predicted_error[known]),
        ):
            self._real(name, values)
        for name, integers in (
            ("hops", pairs.hops[has_path]),
            ("hops_sweet_paths", pairs.hops[sweet]),
            ("hops_decaying_paths", pairs.hops[decaying]),
            ("obstructing_flss_per_path", pairs.obstructing_flss[obstructed_paths]),
        ):
            self._integer(name, integers)
        error = np.linalg.norm(pairs.estimate[known] - pairs.truth[known], axis=1)
        self.known_predictions += int(known.sum())
        self.within_predicted += int((error <= pairs.predicted_error[known]).sum())

    def statistics(self) -> PairStatistics:
        """The summary's per-pair fields (spec, section 6)."""
        total, count = self.pairs, self.counts.get
        described = {name: tally.describe() for name, tally in self.reals.items()}
        described |= {name: tally.describe() for name, tally in self.integers.items()}

        def stats(name: str) -> Stats:
            return described.get(name, NO_VALUES)

        obstructing = self.integers.get("obstructing_flss_per_path", IntegerTally()).counts
        return PairStatistics(
            blind_pairs=total,
            sweet_pairs=count("sweet", 0),
            decaying_pairs=count("decaying", 0),
            no_path_pairs=count("no_path", 0),
            sweet_pct=_pct(count("sweet", 0), total),
            decaying_pct=_pct(count("decaying", 0), total),
            no_path_pct=_pct(count("no_path", 0), total),
            blocked_pairs=count("blocked", 0),
            no_sweet_path_pairs=count("no_sweet_path", 0),
            distance_error_pct=stats("distance_error_pct"),
            distance_error_pct_sweet_paths=stats("distance_error_pct_sweet_paths"),
            distance_error_pct_decaying_paths=stats("distance_error_pct_decaying_paths"),
            alpha_deg=stats("alpha_deg"),
            theta_deg=stats("theta_deg"),
            phi_deg=stats("phi_deg"),
            hops=stats("hops"),
            hops_sweet_paths=stats("hops_sweet_paths"),
            hops_decaying_paths=stats("hops_decaying_paths"),
            sweet_connected_pairs=count("sweet_connected", 0),
            obstructed_path_pct=_pct(count("obstructed", 0), count("sweet_connected", 0)),
            obstructing_flss_per_path=stats("obstructing_flss_per_path"),
            predicted_error_cm=stats("predicted_error_cm"),
            within_predicted_pct=(
                _pct(self.within_predicted, self.known_predictions)
                if self.known_predictions
                else float("nan")
            ),
            obstructing_flss_histogram=tuple(obstructing.tolist()),
            quantiles="exact" if all(one.exact for one in self.reals.values()) else "sketched",
        )


def summarise(
    hood: Neighbourhood,
    policy: str,
    pairs: PairResults | PairTally,
    seconds: float | None = None,
    heuristic: HeuristicFacts | None = None,
    fusion: FusionFacts | None = None,
    fit: FitFacts | None = None,
) -> Summary:
    """The run's metrics (spec, section 6), from its pairs or their tally; ``seconds``, s,
    and a heuristic's, fusion's or fit's facts as the stage that made the pairs gives them."""
    if isinstance(pairs, PairResults):
        tally = PairTally()
        tally.add(pairs)
        pairs = tally
    swarm, sensor = hood.swarm, hood.sensor
    neighbours = hood.counts
    return Summary(
        flss=swarm.size,
        cloud_points=swarm.size + swarm.removed,
        removed=swarm.removed,
        radius=swarm.radius,
        dmin=swarm.dmin,
        beta=swarm.beta,
        kissing_pairs=neighbours.kissing,
        sweet_neighbour_pairs=neighbours.sweet,
        decaying_neighbour_pairs=neighbours.decaying,
        pairs=pairs.statistics(),
        parameters=Parameters(policy, swarm.beta, swarm.radius, sensor.to_dict(), sensor.accurate),
        version=__version__,
        seconds=seconds,
        heuristic=heuristic,
        fusion=fusion,
        fit=fit,
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
