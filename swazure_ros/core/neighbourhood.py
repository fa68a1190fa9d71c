"""What every pair evaluation of one swarm shares: its :class:`Neighbourhood`.

The neighbour pairs within reach, their line of sight, and the graphs the
policies search: S_all (sweet pairs, sight ignored), S_vis (sweet pairs in
sight) and SD_vis (sweet or decaying pairs in sight). :func:`neighbourhood`
computes the whole swarm's; :func:`neighbourhood_of` the pairs of some FLSs;
:func:`moved_neighbourhood` updates one after some FLSs moved;
:func:`without` takes stopped FLSs out of the paths.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from .arrays import IntArray
from .geometry import Swarm
from .graph import Graph, make_graph
from .neighbours import NeighbourCounts, NeighbourPairs, neighbour_pairs, pairs_of
from .progress import SILENT, Progress
from .sensor import DECAYING, SWEET, Sensor, hop_error
from .sight import Grid, build_grid, obstructed, segments_near

if TYPE_CHECKING:
    from scipy.spatial import cKDTree


@dataclass
class NeighbourGraphs:
    """The graphs of one :class:`Neighbourhood` built so far: a record of their own.

    Mutable, and declared so: each graph is built the first time its
    neighbourhood is asked for it, then kept here, so that it is built once
    however many evaluations share the neighbourhood, and never where none
    asks (a simulated world that only senses; a revision of a heuristic's
    moves). A neighbourhood made from another (``dataclasses.replace``,
    :func:`without`) starts with none, since its pairs or the pairs its
    paths may use differ. No lock: the engine asks from one thread.
    """

    sweet_all: Graph | None = None  # S_all: sweet pairs, line of sight ignored
    sweet_visible: Graph | None = None  # S_vis: sweet pairs in line of sight
    any_visible: Graph | None = None  # SD_vis: sweet or decaying pairs in line of sight
    sweet_components: IntArray | None = None  # (N,), connected component of each FLS in S_all


@dataclass(frozen=True)
class Neighbourhood:
    """What every pair evaluation of one swarm shares: pairs, line of sight, graphs.

    The data are frozen; the graphs S_all, S_vis and SD_vis are built from
    them when first asked for and kept in :attr:`graphs`, the record's one
    mutable part (:class:`NeighbourGraphs`).
    """

    swarm: Swarm
    sensor: Sensor
    pairs: NeighbourPairs  # unordered pairs within reach, sorted
    visible: NDArray[np.bool_]  # (len(pairs),), line of sight (False for blind pairs)
    grid: Grid
    usable: NDArray[np.bool_]  # (len(pairs),), pairs the graphs may hold (see without())
    # The whole swarm's counts when ``pairs`` holds only the pairs paths may use (core.blocks).
    kept_counts: NeighbourCounts | None = None
    # The graphs built so far: not an argument, so that every new neighbourhood (a copy
    # by dataclasses.replace included) starts with none.
    graphs: NeighbourGraphs = field(
        default_factory=NeighbourGraphs, init=False, repr=False, compare=False
    )

    @property
    def counts(self) -> NeighbourCounts:
        """How many neighbour pairs of each kind the swarm has."""
        return self.kept_counts or NeighbourCounts.of(self.pairs)

    @property
    def sweet_components(self) -> IntArray:
        """Connected-component label of every FLS in S_all: (N,)."""
        if self.graphs.sweet_components is None:
            self.graphs.sweet_components = self.sweet_all.components()
        return self.graphs.sweet_components

    @property
    def sweet_all(self) -> Graph:
        """S_all: sweet pairs, line of sight ignored."""
        if self.graphs.sweet_all is None:
            self.graphs.sweet_all = self._graph(self.pairs.range_class == SWEET)
        return self.graphs.sweet_all

    @property
    def sweet_visible(self) -> Graph:
        """S_vis: sweet pairs in line of sight."""
        if self.graphs.sweet_visible is None:
            sweet = self.pairs.range_class == SWEET
            self.graphs.sweet_visible = self._graph(sweet & self.visible)
        return self.graphs.sweet_visible

    @property
    def any_visible(self) -> Graph:
        """SD_vis: sweet or decaying pairs in line of sight."""
        if self.graphs.any_visible is None:
            reach = (self.pairs.range_class == SWEET) | (self.pairs.range_class == DECAYING)
            self.graphs.any_visible = self._graph(reach & self.visible)
        return self.graphs.any_visible

    def _graph(self, mask: NDArray[np.bool_]) -> Graph:
        """The graph of the usable pairs where ``mask`` (len(pairs),) holds, with their costs."""
        index = np.flatnonzero(mask & self.usable)
        pairs = self.pairs
        tracking = pairs.tracking[index]
        costs = hop_error(self.sensor, tracking, self.swarm.radius)
        return make_graph(
            self.swarm.size, pairs.first[index], pairs.second[index], tracking, index, costs
        )


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
