"""The simulated world: where every FLS is, and what each one's camera and radio report.

A :class:`World` is ground truth for one swarm. Every process of a swarm builds
the same world from the same inputs (cloud, scale, beta or radius, sensor,
seed); positions then change only by :meth:`World.moved`, which returns the
next revision, so processes that apply the same moves agree. FLS ids are the
FLSs' row numbers in the point cloud, the ids of ``pairs.csv``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.clouds import Cloud
from ..core.errors import UnknownFlsError
from ..core.geometry import Swarm, make_swarm
from ..core.grid import Grid, build_grid, grid_of
from ..core.lookup import sorted_rows
from ..core.neighbourhood import (
    Neighbourhood,
    moved_neighbourhood,
    neighbourhood,
    neighbourhood_of,
)
from ..core.observe import (
    LocalView,
    Measurement,
    NeighbourSets,
    Observations,
    local_view,
    neighbour_sets,
    observations,
    pair_readings,
    readings_of,
)
from ..core.sensor import Sensor
from ..files.description import SwarmDescription

if TYPE_CHECKING:
    from scipy.spatial import cKDTree


class Held(NamedTuple):
    """What a world holds of its swarm, counted: what hosting a share costs a process."""

    pairs: int  # neighbour pairs (``World.hood``)
    rows: int  # observation rows laid out (``World.seen``), each its owner FLS's
    owners: int  # FLSs with rows laid out


class HomeNeighbourhood:
    """Revision 0's neighbourhood of a world: held, or let go once the observations are laid
    out and made again the first time something asks for it (``pairs_on_demand``).

    A further process of a packed swarm lays out its FLSs' observations from its pairs and
    then, in plain discovery, never asks for them again: at torus:30000 over 4 they are
    1.3 GB a process (41 M pairs). A move asks for them; they are made anew from revision
    0's places, the same pairs. A world whose decaying rows are laid out on demand keeps
    them here once made (``full_seen``): revision 0's, whichever revision asks.
    """

    def __init__(
        self, hood: Neighbourhood, make: Callable[[], Neighbourhood] | None = None
    ) -> None:
        self._built_pairs = len(hood.pairs)  # counted while held, for :meth:`World.held`
        self._make = make
        self.held: Neighbourhood | None = hood if make is None else None
        # Revision 0's rows with the decaying ones, where the world laid out its blind
        # and sweet rows only (``decaying_on_demand``): made when first asked for.
        self.full_seen: Observations | None = None

    @property
    def pairs(self) -> int:
        """The pairs it holds, or held when it was built."""
        return self._built_pairs if self.held is None else len(self.held.pairs)

    def get(self) -> Neighbourhood:
        """The neighbourhood, made again if it was let go."""
        if self.held is None:
            assert self._make is not None  # let go only where it can be made again
            self.held = self._make()
        return self.held


@dataclass
class WorkedOut:
    """What a :class:`World` worked out of its revision so far; None: not yet.

    The world stays one frozen revision; this is its honest scratchpad, which
    ``dataclasses.replace`` leaves behind (a new revision starts empty).
    """

    hood: Neighbourhood | None = None
    seen: Observations | None = None
    laid_out: NDArray[np.bool_] | None = None
    grid: Grid | None = None
    tree: cKDTree | None = None
    one_seen: dict[int, Observations] = field(default_factory=dict)


@dataclass(frozen=True)
class World:
    """Ground truth of one swarm at one revision, with every FLS's observations.

    A revision's neighbourhood is worked out when something needs all of it
    (:attr:`hood`, :attr:`seen`); one FLS's senses need only that FLS's pairs.
    While a heuristic moves hundreds of FLSs a revision and only the FLSs on a
    few paths measure, that is most of the difference in cost.
    """

    cloud: Cloud
    sensor: Sensor
    home: Swarm  # the FLSs at their points of the cloud
    swarm: Swarm  # the FLSs where they are now
    revision: int
    # Revision 0's, kept because a heuristic returns every FLS home after each batch.
    home_neighbourhood: HomeNeighbourhood
    home_seen: Observations
    # The neighbourhood of this revision or an earlier one (None: revision 0's), and the
    # FLSs (indices) whose places differ from it.
    known: Neighbourhood | None
    moved_since: IntArray
    # The FLSs (sorted indices) whose observations this world lays out; None: every
    # FLS. A process hosting a share holds its FLSs' rows, asked of others on demand.
    hosted: IntArray | None = None
    # True: the neighbourhoods hold the hosted FLSs' pairs only (and a moved FLS's).
    only_hosted_pairs: bool = False
    # True: revision 0's observations hold the blind and sweet rows only; an FLS's decaying
    # rows are laid out when something asks for them (:meth:`view`).
    decaying_on_demand: bool = False
    # The cell edge of every revision's line-of-sight grid, cm: revision 0's (0: each
    # revision's own spacing). A grid's cells change how fast a segment is scanned, never
    # what the scan finds, and measuring a moved swarm's spacing again took a heuristic's
    # batch longer than its walks' line of sight (6 ms a revision at 3,720 FLSs).
    sight_cell: float = 0.0

    # Worked out on demand, per revision: `replace` gives the next revision an empty one.
    _worked: WorkedOut = field(default_factory=WorkedOut, init=False, repr=False, compare=False)

    @property
    def home_hood(self) -> Neighbourhood:
        """Revision 0's neighbourhood (made again if it was let go: ``pairs_on_demand``)."""
        return self.home_neighbourhood.get()

    @property
    def _at_home(self) -> bool:
        """Whether this revision's places are revision 0's, as far as is known."""
        return self.known is None and not len(self.moved_since)

    @property
    def hood(self) -> Neighbourhood:
        """Every pair within sensor reach, with line of sight; in a world made with
        ``only_hosted_pairs``, the hosted FLSs' pairs (and those of FLSs that moved)."""
        if self._worked.hood is None:
            known = self.home_hood if self.known is None else self.known
            self._worked.hood = moved_neighbourhood(known, self.swarm, self.moved_since)
        return self._worked.hood

    @property
    def seen(self) -> Observations:
        """Every hosted FLS's observations (every FLS's when ``hosted`` is None)."""
        if self._worked.seen is None:
            # At home the observations are revision 0's, without asking for its pairs.
            hood = None if self._at_home else self.hood
            if hood is None or hood is self.home_neighbourhood.held:
                self._worked.seen = self.home_seen
            else:
                self._worked.seen = observations(hood, self.hosted)
        return self._worked.seen

    @property
    def _laid_out(self) -> NDArray[np.bool_]:
        """(N,) whether :attr:`seen` holds each FLS's rows."""
        if self._worked.laid_out is None:
            laid_out = np.zeros(self.swarm.size, dtype=bool)
            laid_out[slice(None) if self.hosted is None else self.hosted] = True
            self._worked.laid_out = laid_out
        return self._worked.laid_out

    @property
    def _grid(self) -> Grid:
        if self._worked.grid is None:
            points = self.swarm.points
            self._worked.grid = (
                grid_of(points, self.sight_cell)
                if self.sight_cell > 0
                else build_grid(points, self.swarm.radius)
            )
        return self._worked.grid

    @property
    def _tree(self) -> cKDTree:
        if self._worked.tree is None:
            from scipy.spatial import cKDTree  # here: a verb's --help need not import scipy

            self._worked.tree = cKDTree(self.swarm.points)
        return self._worked.tree

    @property
    def _seen_at_hand(self) -> bool:
        """Whether the whole swarm's observations of this revision cost nothing to ask."""
        return self._worked.seen is not None or not len(self.moved_since)

    def _worked_out(self, index: int) -> bool:
        """Whether FLS ``index``'s observations of this revision are at hand."""
        laid_out = self._seen_at_hand and self._laid_out[index]
        if laid_out and self._seen_near:  # its decaying rows too, or a walk misses them
            laid_out = self.home_neighbourhood.full_seen is not None
        return laid_out or index in self._worked.one_seen

    @property
    def _seen_near(self) -> bool:
        """Whether :attr:`seen` lacks the decaying rows (revision 0's, laid out without)."""
        return self.decaying_on_demand and self.seen is self.home_seen

    def _observed(self, index: int, decaying: bool = True, whole: bool = False) -> Observations:
        """Observations that hold FLS ``index``'s rows (the hosted FLSs', or its own).

        ``decaying``: with its decaying rows in sight; else its blind and sweet rows
        at least. ``whole``: where the decaying rows are laid out on demand, lay out
        every hosted FLS's at once rather than this FLS's alone (a decaying phase
        asks for all of them).
        """
        if self._seen_at_hand and self._laid_out[index]:
            if not decaying or not self._seen_near:
                return self.seen
            home = self.home_neighbourhood
            if home.full_seen is None and whole:
                home.full_seen = observations(self.home_hood, self.hosted)
            if home.full_seen is not None:
                return home.full_seen
        one = self._worked.one_seen.get(index)
        if one is not None:
            return one
        hood = neighbourhood_of(self.swarm, self.sensor, np.array([index]), self._grid, self._tree)
        one = self._worked.one_seen[index] = observations(hood)
        return one

    @property
    def ids(self) -> IntArray:
        """(N,) FLS ids, in swarm order."""
        return self.swarm.cloud_index

    def index(self, fls_id: int) -> int:
        """Swarm index of FLS ``fls_id``; UnknownFlsError when the swarm has none."""
        return int(self.indices([fls_id])[0])

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """FLS ``fls_id``'s neighbour sets, as FLS ids."""
        index = self.index(fls_id)
        sets = neighbour_sets(self._observed(index), index)
        return NeighbourSets(*(self.ids[indices] for indices in vars(sets).values()))

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours, for path discovery: every row."""
        index = self.index(fls_id)
        return local_view(self._observed(index, whole=True), self.ids, index)

    def near_view(self, fls_id: int) -> LocalView | None:
        """FLS ``fls_id``'s view with its blind and sweet rows only, where the decaying ones
        are laid out on demand and not yet (most of a display's rows): what the sweet
        phases of a discovery relay over and search for. None where its whole
        :meth:`view` is at hand."""
        index = self.index(fls_id)
        if self._worked_out(index) or not (self._seen_at_hand and self._laid_out[index]):
            return None
        return local_view(self._observed(index, decaying=False), self.ids, index)

    def held(self) -> Held:
        """What this world holds at its revision, counted (:class:`Held`)."""
        seen = self.seen
        full = self.home_neighbourhood.full_seen if self._seen_near else None
        if full is not None:
            seen = full  # the decaying rows laid out since: the blind and sweet ones again
        owners = int(np.count_nonzero(np.diff(seen.indptr)))
        pairs = self.home_neighbourhood.pairs if self._at_home else len(self.hood.pairs)
        rows = len(seen.other) + (len(self.seen.other) if full is not None else 0)
        return Held(pairs, rows, owners)

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""
        return int(self.ids[-1]) + 1

    def measurement(self, fls_id: int, of: Sequence[int] | None = None) -> Measurement:
        """What FLS ``fls_id``'s camera measures now; with ``of`` (ids), of those FLSs only.

        A path walk asks an FLS for its next hop alone: in a revision whose
        neighbourhood nobody has worked out, that is one pair to judge, not
        every pair within the FLS's reach.
        """
        index = self.index(fls_id)
        if of is not None and not self._worked_out(index):
            read = readings_of(self.swarm, self.sensor, index, self.indices(of), self._grid)
            return Measurement(self.ids[read.other], read.range_class, read.vector, read.tracking)
        seen = self._observed(index)
        rows = seen.rows(index)
        measured = seen.measured_in(rows)
        if of is not None:
            measured &= np.isin(self.ids[seen.other[rows]], np.asarray(of, dtype=np.int64))
        return Measurement(
            self.ids[seen.other[rows][measured]],
            seen.range_class[rows][measured],
            seen.vector_at(rows)[measured],
            seen.tracking_at(rows)[measured],
        )

    def hop_measurements(
        self, fls_ids: Sequence[int], next_ids: Sequence[int]
    ) -> list[Measurement]:
        """What FLS ``fls_ids[k]``'s camera measures now of FLS ``next_ids[k]`` alone, for each
        k: ``measurement(fls_ids[k], [next_ids[k]])``, the hops of a path walk through the
        FLSs a process hosts read at once."""
        owners, others = self.indices(fls_ids), self.indices(next_ids)
        # An FLS whose rows this revision holds reads them; the others' hops are judged
        # together, pair by pair.
        alone = np.array([not self._worked_out(int(index)) for index in owners], dtype=bool)
        hops = pair_readings(self.swarm, self.sensor, owners[alone], others[alone], self._grid)
        pair_of, row_of = np.cumsum(alone) - 1, np.cumsum(hops.read) - 1
        out = []
        for k, (fls, other) in enumerate(zip(fls_ids, next_ids, strict=True)):
            if not alone[k]:
                out.append(self.measurement(fls, [other]))
                continue
            pair = int(pair_of[k])
            read = int(hops.read[pair])  # one row, or none
            row = slice(row_of[pair], row_of[pair] + read)
            out.append(
                Measurement(
                    self.ids[others[k : k + read]],
                    hops.range_class[pair : pair + read],
                    hops.vector[row],
                    hops.tracking[row],
                )
            )
        return out

    def position(self, fls_id: int) -> FloatArray:
        """(3,) where FLS ``fls_id`` is now, cm."""
        return np.asarray(self.swarm.points[self.index(fls_id)])

    def lookup(self, fls_ids: ArrayLike) -> tuple[IntArray, NDArray[np.bool_]]:
        """Swarm indices (K,) of FLSs ``fls_ids`` (K,), and whether each is in the swarm."""
        return sorted_rows(self.ids, fls_ids)

    def indices(self, fls_ids: ArrayLike) -> IntArray:
        """Swarm indices (K,) of FLSs ``fls_ids`` (K,); UnknownFlsError if one is not here."""
        rows, known = self.lookup(fls_ids)
        if not known.all():
            fls_id = int(np.asarray(fls_ids).reshape(-1)[~known][0])
            raise UnknownFlsError(
                f"no FLS {fls_id} in this swarm of {len(self.ids)} FLSs "
                f"(ids {self.ids[0]}..{self.ids[-1]})"
            )
        return rows

    def moved(self, positions: dict[int, FloatArray], revision: int | None = None) -> World:
        """The world with FLSs moved to ``positions`` (id -> (3,) cm), at the next revision."""
        ids = np.fromiter(positions, dtype=np.int64, count=len(positions))
        points = np.array(list(positions.values()), dtype=np.float64).reshape(-1, 3)
        return self.placed(ids, points, revision)

    def placed(self, fls_ids: ArrayLike, at: FloatArray, revision: int | None = None) -> World:
        """The world with FLSs ``fls_ids`` (K,) at ``at`` (K, 3), cm, at the next revision."""
        points = self.swarm.points.copy()
        points[self.indices(fls_ids)] = at
        next_revision = self.revision + 1 if revision is None else revision
        if np.array_equal(points, self.home.points):
            return replace(
                self,
                swarm=self.home,
                revision=next_revision,
                known=None,
                moved_since=np.zeros(0, dtype=np.int64),
            )
        # From the newest neighbourhood worked out: only what moved since is sensed anew.
        known = self.known if self._worked.hood is None else self._worked.hood
        before = self.home if known is None else known.swarm
        moved_since = np.flatnonzero((points != before.points).any(axis=1))
        return replace(
            self,
            swarm=replace(self.swarm, points=points),
            revision=next_revision,
            known=known,
            moved_since=moved_since,
        )


def make_world(
    cloud: Cloud,
    sensor: Sensor,
    beta: float | None = None,
    radius: float | None = None,
    seed: int = 0,
    hosted_ids: Sequence[int] | None = None,
    only_hosted_pairs: bool = False,
    pairs_on_demand: bool = False,
    decaying_on_demand: bool = False,
) -> World:
    """The world of ``cloud`` at revision 0: FLSs at their points, colliding ones removed.

    ``hosted_ids`` (FLS ids) are the FLSs whose observations it lays out (every
    FLS's when None); any other FLS's are worked out when asked. With
    ``only_hosted_pairs``, its neighbourhood holds only the pairs of the hosted
    FLSs (:func:`~swazure_ros.core.neighbourhood.neighbourhood_of`), each as the
    whole swarm's neighbourhood has it: what a process hosting a share needs, not
    the whole swarm's pairs. With ``pairs_on_demand`` too, those pairs are let go
    once the observations are laid out, and made again when something asks for
    them (:class:`HomeNeighbourhood`). With ``decaying_on_demand``, it finds
    and lays out the blind and sweet pairs only; the decaying ones (most of a
    display's pairs, rows and line of sight) are found when something asks for
    an FLS's every row (:meth:`World.view`), and every pair when something asks
    for the neighbourhood.
    """
    swarm = make_swarm(cloud.points, beta=beta, radius=radius, seed=seed)
    hosted = None
    if hosted_ids is not None:
        hosted = np.unique(np.asarray(hosted_ids, dtype=np.int64))
        rows, found = sorted_rows(swarm.cloud_index, hosted)
        if not found.all():
            raise UnknownFlsError(f"hosted FLSs not in this swarm of {swarm.size} FLSs")
        hosted = rows if len(hosted) < swarm.size else None
    lean = only_hosted_pairs and hosted is not None
    make: Callable[[], Neighbourhood] = partial(neighbourhood, swarm, sensor)
    if only_hosted_pairs and hosted is not None:
        make = partial(neighbourhood_of, swarm, sensor, hosted)
    if decaying_on_demand:
        # Pairs below the sweet range's end are blind or sweet: never decaying.
        owners = np.arange(swarm.size) if hosted is None else hosted
        hood = neighbourhood_of(swarm, sensor, owners, longest=sensor.sweet_max)
    else:
        hood = make()
    seen = observations(hood, hosted)
    on_demand = pairs_on_demand or decaying_on_demand
    home = HomeNeighbourhood(hood, make if on_demand else None)
    no_moves = np.zeros(0, dtype=np.int64)
    return World(
        cloud, sensor, swarm, swarm, 0, home, seen, None, no_moves, hosted, lean,
        decaying_on_demand, hood.grid.cell,
    )  # fmt: skip


@dataclass(frozen=True)
class WorldSpec(SwarmDescription):
    """A swarm's description, from which every process builds the same ground truth."""

    def build(
        self,
        hosted_ids: Sequence[int] | None = None,
        only_hosted_pairs: bool = False,
        pairs_on_demand: bool = False,
        decaying_on_demand: bool = False,
    ) -> World:
        """Load the cloud and sensor and make the world at revision 0 (see :func:`make_world`)."""
        return make_world(
            self.cloud_of(),
            self.sensor(),
            beta=self.beta,
            radius=self.radius,
            seed=self.seed,
            hosted_ids=hosted_ids,
            only_hosted_pairs=only_hosted_pairs,
            pairs_on_demand=pairs_on_demand,
            decaying_on_demand=decaying_on_demand,
        )
