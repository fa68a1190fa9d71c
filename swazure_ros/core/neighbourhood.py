"""What every pair evaluation of one swarm shares: its :class:`Neighbourhood`.

The neighbour pairs within reach, their line of sight, and the graphs the
policies search: S_all (sweet pairs, sight ignored), S_vis (sweet pairs in
sight) and SD_vis (sweet or decaying pairs in sight). :func:`neighbourhood`
computes the whole swarm's; :func:`neighbourhood_of` the pairs of some FLSs;
:func:`moved_neighbourhood` updates one after some FLSs moved;
:func:`without` takes stopped FLSs out of the paths.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray, IntArray
from .geometry import Swarm
from .graph import Graph, make_graph
from .grid import Grid, build_grid
from .hop_errors import hop_error
from .neighbours import NeighbourCounts, NeighbourPairs, neighbour_pairs, pairs_of
from .progress import SILENT, Progress
from .sensor import DECAYING, SWEET, Sensor
from .sight import obstructed, segments_near

if TYPE_CHECKING:
    from scipy.spatial import cKDTree

#: Bands of length in each row of SD_vis: its edges run from the sweet range's start to the
#: decaying range's end (6 to 30 cm published), and a search bounded by its targets' cost
#: reads only the bands it can afford (docs/core.md, "Why it is fast"). S_all and S_vis
#: hold sweet edges alone (6 to 8 cm): one band, the row, sorted by neighbour, which
#: Move Source's helpers are taken in the order of.
ANY_VISIBLE_BANDS = 8


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
    # (N,) each, the components of S_vis and SD_vis: every block of pairs searches them.
    sweet_visible_components: IntArray | None = None
    any_visible_components: IntArray | None = None


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

    def forget_graphs(self) -> None:
        """Let go of the graphs built so far; each is built again if asked for.

        For a neighbourhood another has taken over from (a display's sweet pairs,
        once its decaying pairs in sight join them: :mod:`.blocks`), whose graphs
        would otherwise be held as long as anything refers to it.
        """
        for name in fields(self.graphs):
            setattr(self.graphs, name.name, None)

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
    def sweet_visible_components(self) -> IntArray:
        """Connected-component label of every FLS in S_vis: (N,)."""
        if self.graphs.sweet_visible_components is None:
            self.graphs.sweet_visible_components = self.sweet_visible.components()
        return self.graphs.sweet_visible_components

    @property
    def any_visible_components(self) -> IntArray:
        """Connected-component label of every FLS in SD_vis: (N,)."""
        if self.graphs.any_visible_components is None:
            self.graphs.any_visible_components = self.any_visible.components()
        return self.graphs.any_visible_components

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
            self.graphs.any_visible = self._graph(reach & self.visible, ANY_VISIBLE_BANDS)
        return self.graphs.any_visible

    def _graph(self, mask: NDArray[np.bool_], bands: int = 1) -> Graph:
        """The graph of the usable pairs where ``mask`` (len(pairs),) holds, with their costs,
        its rows in ``bands`` bands of length."""
        pairs = self.pairs
        # The pairs picked out, not copied, and the costs only when the least-error policy
        # asks: at display scale a graph is tens of millions of entries.
        costs = partial(_hop_costs, self.sensor, self.swarm.radius)
        return make_graph(
            self.swarm.size,
            pairs.first,
            pairs.second,
            pairs.tracking,
            cost_of=costs,
            keep=mask & self.usable,
            bands=bands,
            positions=self.swarm.points,
        )


def _hop_costs(sensor: Sensor, radius: float, tracking: FloatArray) -> FloatArray:
    """:func:`.hop_errors.hop_error` with the tracking distances last (for ``partial``)."""
    return hop_error(sensor, tracking, radius)


def neighbourhood(swarm: Swarm, sensor: Sensor, progress: Progress | None = None) -> Neighbourhood:
    """The whole swarm's neighbour pairs, their line of sight, and its graphs when asked for.

    Parameters
    ----------
    swarm : Swarm
        N FLSs: points (N, 3), cm, and radius r, cm.
    sensor : Sensor
        Its ranges classify each pair by tracking distance, cm.
    progress : Progress, optional
        Told of the line-of-sight stage.

    Returns
    -------
    Neighbourhood
        Every unordered pair within the sensor's reach (blind, sweet or
        decaying), sorted, with the line of sight of each sweet and decaying
        pair; the graphs S_all, S_vis and SD_vis are built when first asked for.

    Examples
    --------
    Three FLSs in a V, A-B and B-C sweet and A-C blind, and a fourth FLS on
    the segment A-B, which blocks it:

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> hood.pairs.first.tolist(), hood.pairs.second.tolist()
    ([0, 0, 0, 1, 1, 2], [1, 2, 3, 2, 3, 3])
    >>> hood.visible.tolist()  # A-B blocked by the fourth FLS, B-C in sight, the rest blind
    [False, False, False, True, False, False]
    >>> hood.sweet_all.edges, hood.sweet_visible.edges
    (2, 1)
    """
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


#: neighbourhood_of finds the pairs of at least one FLS in this many by the whole list's pass.
MANY_FLSS = 8


def neighbourhood_of(
    swarm: Swarm,
    sensor: Sensor,
    flss: ArrayLike,
    grid: Grid | None = None,
    tree: cKDTree | None = None,
    longest: float | None = None,
) -> Neighbourhood:
    """The pairs that involve some FLSs, with their line of sight: a part of :func:`neighbourhood`.

    Each of these FLSs' pairs equals that of ``neighbourhood(swarm, sensor)``;
    the pairs between other FLSs are left out.

    Parameters
    ----------
    swarm : Swarm
        N FLSs.
    sensor : Sensor
        The sensor whose ranges classify the pairs.
    flss : (K,) array_like of int
        Swarm indices, in any order, repeats allowed.
    grid : Grid, optional
        ``build_grid(swarm.points, swarm.radius)``, when the caller keeps it.
    tree : cKDTree, optional
        A cKDTree of ``swarm.points``, when the caller keeps it.
    longest : float, optional
        Only the pairs with tracking distance below this, cm: with
        ``sensor.sweet_max``, the blind and sweet pairs without the decaying
        ones, which are most of a display's pairs and of its line of sight.

    Returns
    -------
    Neighbourhood
        The pairs of which one FLS or both are among ``flss``, sorted.

    Raises
    ------
    ValueError
        An index of ``flss`` is not an FLS of ``swarm``.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> part = neighbourhood_of(swarm, sensor, [2])
    >>> list(zip(part.pairs.first.tolist(), part.pairs.second.tolist()))
    [(0, 2), (1, 2), (2, 3)]
    """
    flss = _indices(flss, "flss", swarm.size)
    if len(flss) * MANY_FLSS >= swarm.size or longest is not None:
        # A share of a swarm: the whole list's compiled pass costs less than a tree's
        # Python lists of that many FLSs' neighbours. It keeps these FLSs' pairs only,
        # never holding the whole list (126.7 M pairs at torus:30000), and line of sight,
        # the most of the work, is judged for them alone.
        mine = np.zeros(swarm.size, dtype=bool)
        mine[flss] = True
        pairs = neighbour_pairs(swarm, sensor, involving=mine, longest=longest)
    else:
        pairs = pairs_of(swarm, sensor, flss, tree)
    edge = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    grid = grid or build_grid(swarm.points, swarm.radius)
    visible = np.zeros(len(pairs), dtype=bool)
    visible[edge] = ~obstructed(
        swarm.points, swarm.radius, pairs.first[edge], pairs.second[edge], grid
    )
    return Neighbourhood(swarm, sensor, pairs, visible, grid, np.ones(len(pairs), dtype=bool))


def moved_neighbourhood(hood: Neighbourhood, swarm: Swarm, moved: ArrayLike) -> Neighbourhood:
    """``hood`` again after some FLSs moved, at a cost in proportion to what moved.

    Equal to ``neighbourhood(swarm, hood.sensor)``: the pairs of the moved
    FLSs are found anew, and line of sight is judged again only for those
    pairs and for the segments that pass within r of a moved FLS's old or new
    place (an FLS obstructs a segment within r of its centre); every other
    pair keeps its line of sight.

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood before the moves.
    swarm : Swarm
        The same N FLSs, where those at ``moved`` have new points, cm.
    moved : (K,) array_like of int
        Swarm indices of the FLSs that moved.

    Returns
    -------
    Neighbourhood
        The neighbourhood of ``swarm``; ``hood`` itself when nothing moved.

    Raises
    ------
    ValueError
        ``swarm`` has another number of FLSs than ``hood``'s, or an index of
        ``moved`` is not an FLS of it.

    Examples
    --------
    The FLS on the segment A-B steps aside, and A sees B:

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> from dataclasses import replace
    >>> aside = replace(swarm, points=swarm.points + [[0, 0, 0], [0, 0, 0], [0, 0, 0], [0, 0, 3]])
    >>> bool(moved_neighbourhood(neighbourhood(swarm, sensor), aside, [3]).visible[0])  # A-B
    True
    """
    if swarm.size != hood.swarm.size:
        raise ValueError(f"`swarm` must have the {hood.swarm.size} FLSs of `hood`: {swarm.size}")
    moved = _indices(moved, "moved", swarm.size)
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


def without(hood: Neighbourhood, gone: ArrayLike) -> Neighbourhood:
    """``hood`` with no path through some FLSs, whose bodies still block: they stopped answering.

    Line of sight is unchanged, since a stopped FLS has not left its place;
    the graphs leave out every pair of the stopped FLSs.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    gone : (K,) array_like of int
        Swarm indices of the stopped FLSs.

    Returns
    -------
    Neighbourhood
        ``hood``'s pairs and sight, with its own graphs.

    Raises
    ------
    ValueError
        An index of ``gone`` is not an FLS of ``hood``'s swarm.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> hood.sweet_all.edges, without(hood, [1]).sweet_all.edges
    (2, 0)
    """
    gone = _indices(gone, "gone", hood.swarm.size)
    pairs = hood.pairs
    usable = ~(np.isin(pairs.first, gone) | np.isin(pairs.second, gone))
    return replace(hood, usable=usable)


def _indices(indices: ArrayLike, name: str, size: int) -> IntArray:
    """``indices``, sorted without repeats, once checked to be FLSs of a swarm of ``size``."""
    unique = np.unique(np.asarray(indices, dtype=np.int64))
    if unique.ndim != 1 or (len(unique) and (unique[0] < 0 or unique[-1] >= size)):
        raise ValueError(f"`{name}` must be swarm indices of FLSs, 0 to {size - 1}")
    return unique
