"""Decaying paths searched near their pairs: SD_vis in regions, never held whole.

A pair without a sweet path in sight takes the policy's path in SD_vis, the
sweet and decaying pairs in sight (:func:`.evaluate.evaluate_pairs`). At
display scale SD_vis is the largest thing a run holds (the race car at
65,536 FLSs: 3.4 GB, most of its peak). Here each such pair is searched in
the SD_vis of a region around its source instead, regions a few at a time
within a budget, and only the decaying pairs its path hops over are kept.

Why a region gives the whole graph's path. Every edge of SD_vis costs at
least ``ratio`` per cm between its ends (:func:`least_cost_per_cm`: a
tracking distance at least ``sweet_min``, or one hop at most the sensor's
reach), so every node of every path of cost c or less from s to t lies in
the ellipsoid ``|v - s| + |v - t| <= c / ratio``, inside the ball of radius
``(c / ratio + |s - t|) / 2`` about s. A region holds every edge with both
ends in it. Its search finds a cost c' no less than SD_vis's; when that ball
for c' lies in the region, the whole graph's path of least cost lies in it
too, and so does every predecessor the tie-break weighs (each lies on a path
of least cost), with the same sums in the same order: the same cost, hops and
nodes (:mod:`.search`'s labels do not depend on the order of a node's
offers). A region is every FLS within its radius of one of its sources, so
it holds that ball about each. A pair the region does not join is proven
apart when every FLS of its source's part of the region lies within the
radius less a sensor's reach of a source, where no edge can leave it. Any
other pair is searched again in a region whose radius its found path needs,
or a little wider (:data:`WIDER`): a region that holds every FLS and every
decaying pair is the whole graph.

Nor does a region hold every decaying pair between its FLSs. An edge on such
a path leaves the rest of the path less of the ball the longer it is
(:func:`longest_edge`): where a region's radius is a few sweet hops, only the
decaying pairs a little beyond the sweet range can be on its paths, and only
their sight is judged. A region without the longer pairs proves no pair
apart: a pair it does not join is searched again, wider, until its region
holds every decaying pair.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from typing import NamedTuple

import numpy as np

from . import csr
from .arrays import BoolArray, FloatArray, IntArray
from .judged_sight import JudgedSight
from .neighbourhood import Neighbourhood
from .neighbours import NeighbourPairs, neighbour_pairs, sensor_reach
from .pair_scan import EVERY_PAIR, Affordable
from .partition import kd_split
from .path_arrays import Paths, path_hops
from .paths import FEWEST_HOPS, LEAST_ERROR, check_policy, shortest_paths
from .progress import Progress
from .sensor import DECAYING, SWEET, Sensor
from .threads import side_by_side


def least_cost_per_cm(sensor: Sensor, radius: float, policy: str) -> float:
    """The least cost an edge of SD_vis has per cm between its FLSs' centres, under ``policy``.

    A sweet or decaying pair's tracking distance t is at least ``sweet_min``
    (below it a pair is blind) and below the larger of ``sweet_max`` and
    ``decaying_max``; its centres are ``t + 2r`` apart. Shortest-length sums
    t, so an edge costs at least ``sweet_min / (sweet_min + 2r)`` a cm;
    fewest-hops counts hops, one per at most ``reach + 2r`` cm.

    Parameters
    ----------
    sensor : Sensor
    radius : float
        The FLS radius r, cm.
    policy : {'fewest-hops', 'shortest-length', 'least-error'}

    Returns
    -------
    float
        Cost per cm, a hair below the bound (1e-9 of it) so that rounding
        never makes it too large; 0 for least-error, whose edge costs (a
        sensor's error model) have no bound here.

    Examples
    --------
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0)
    >>> round(least_cost_per_cm(sensor, 0.5, "shortest-length"), 6)  # 6 / 7
    0.857143
    >>> round(1 / least_cost_per_cm(sensor, 0.5, "fewest-hops"), 6)  # a hop spans under 31 cm
    31.0
    """
    policy = check_policy(policy)
    if policy == LEAST_ERROR:
        return 0.0
    if policy == FEWEST_HOPS:
        least = 1.0 / (max(sensor.sweet_max, sensor.decaying_max) + 2.0 * radius)
    else:
        least = sensor.sweet_min / (sensor.sweet_min + 2.0 * radius)
    return least * (1.0 - 1e-9)


def longest_edge(policy: str, ratio: float, radius: float, region_radius: float) -> float:
    """The longest tracking distance, cm, of an SD_vis edge on any path a region must hold.

    A path of cost c from s to t that hops from u to v over an edge of cost w
    spends at least ``ratio`` a cm on the rest, so
    ``|s - u| + |s - v| + w / ratio <= c / ratio + |s - t| = 2R``, R the
    radius of the ball its nodes lie in (:func:`local_decaying_paths`). The
    edge's ends are at least its tracking distance and 2r apart: an edge of
    shortest-length cost w spans at most ``(2R - 2r) / (1 + 1 / ratio)`` of
    tracking distance, one of fewest-hops ``2R - 1 / ratio - 2r``. At display
    scale most decaying pairs are far longer than a blind pair's path needs.

    Parameters
    ----------
    policy : {'fewest-hops', 'shortest-length'}
    ratio : float
        :func:`least_cost_per_cm`'s, positive.
    radius : float
        The FLS radius r, cm.
    region_radius : float
        The widest R among the region's sources, cm.

    Returns
    -------
    float
        Tracking distance, cm, a hair above the bound (1e-9 of it); edges as
        long or longer lie on no such path.

    Examples
    --------
    >>> round(longest_edge("shortest-length", 0.75, 0.5, 8.0), 6)  # (16 - 1) / (1 + 4 / 3)
    6.428571
    >>> round(longest_edge("fewest-hops", 1 / 31, 0.5, 40.0), 6)  # 80 - 31 - 1
    48.0
    """
    policy = check_policy(policy)
    if policy == FEWEST_HOPS:
        longest = 2.0 * region_radius - 1.0 / ratio - 2.0 * radius
    else:
        longest = (2.0 * region_radius - 2.0 * radius) / (1.0 + 1.0 / ratio)
    return longest * (1.0 + 1e-9)


@dataclass(frozen=True)
class LocalPaths:
    """The SD_vis paths of M pairs, searched in regions (:func:`local_decaying_paths`)."""

    paths: Paths  # one per pair, in the pairs' order
    hopped: NeighbourPairs  # the decaying pairs the paths hop over, sorted, each once
    rounds: int  # passes over the pairs not yet proven, each with a wider margin
    regions: int  # regions searched in all rounds
    judged: int  # decaying pairs whose line of sight the regions judged, each once
    radius: FloatArray  # (M,) the radius about its source of the region that proved each, cm


def local_decaying_paths(
    sweet: Neighbourhood,
    policy: str,
    source: IntArray,
    target: IntArray,
    candidates: IntArray,
    limit: int,
    progress: Progress,
) -> LocalPaths:
    """Each pair's path in SD_vis, as the whole graph gives it, searched near the pair.

    Parameters
    ----------
    sweet : Neighbourhood
        The swarm's sweet pairs and their line of sight (a lean
        neighbourhood's, :mod:`.blocks`): its swarm, sensor and grid.
    policy : {'fewest-hops', 'shortest-length'}
        Least-error has no bound of its cost per cm (:func:`least_cost_per_cm`).
    source, target : (M,) ndarray of int
        The pairs, sorted by source.
    candidates : (N,) ndarray of int
        Each FLS's candidate pairs as first (:func:`.neighbours.pair_counts`):
        a region weighs its FLSs times the swarm's mean candidate pairs per FLS,
        times the share of them within its cut (:func:`longest_edge`).
    limit : int
        The weight a region may have where cutting its sources in two pays
        (:data:`MOST_OVERLAP`), or :data:`OVERLOADED` times it where it does
        not; a region of one source may weigh more.
    progress : Progress
        Told of the stage "decaying paths near their pairs", in pairs.

    Returns
    -------
    LocalPaths

    Raises
    ------
    ValueError
        The least-error policy, or pairs not sorted by source.
    """
    ratio = least_cost_per_cm(sweet.sensor, sweet.swarm.radius, policy)
    if ratio <= 0.0:
        raise ValueError(f"the {policy} policy's paths cannot be searched near their pairs")
    if np.any(np.diff(source) < 0):
        raise ValueError("the pairs must be sorted by source")
    swarm, sensor = sweet.swarm, sweet.sensor
    points = swarm.points
    # A first margin: what a path of two sweet hops between two blind FLSs needs.
    two_hops = 2.0 if policy == FEWEST_HOPS else 2.0 * sensor.sweet_max
    margins = np.full(len(source), (two_hops / ratio + sensor.sweet_min + 2.0 * swarm.radius) / 2)
    progress.start("decaying paths near their pairs", len(source))
    pending = np.arange(len(source), dtype=np.int64)
    kept: list[tuple[IntArray, Paths]] = []
    hopped: list[NeighbourPairs] = []
    rounds = regions = 0
    proven_in = np.zeros(len(source))
    sight = JudgedSight(swarm.size)
    weights = _Weights(sweet, policy, ratio, candidates)
    while len(pending):
        rounds += 1
        settled = [np.empty(0, dtype=np.int64)]
        tiles = _tiles(points, source[pending], margins[pending], weights, limit)
        regions_of = ((tile, pending[np.isin(source[pending], tile)]) for tile in tiles)
        search = partial(_searched_region, sweet, policy, ratio, source, target, margins, sight)
        for found in side_by_side(search, regions_of, REGIONS_AT_ONCE, "region"):
            regions += 1
            rows, done = found.rows, np.flatnonzero(found.proven)
            if len(done):
                proven_in[rows[done]] = found.radius[done]
                kept.append((rows[done], found.paths.take(done)))
                hopped.append(found.hopped)
                progress.advance(len(done))
            settled.append(rows[done])
        pending = np.setdiff1d(pending, np.concatenate(settled), assume_unique=True)
    paths = _in_order(len(source), kept)
    return LocalPaths(paths, _sorted_once(hopped), rounds, regions, sight.judged, proven_in)


#: Regions searched at once, each on a thread of its own: a region's numpy work between
#: its compiled kernels leaves a core idle much of its time, which another region fills.
#: Their results are taken in order, so the run is the same with one at a time; one at a
#: time where numba's threading layer is not threadsafe (:func:`.threads.side_by_side`).
REGIONS_AT_ONCE = 2


class _Searched(NamedTuple):
    """What one region found for its pairs (rows of the pairs searched)."""

    rows: IntArray  # (R,)
    paths: Paths  # (R,) each pair's path in the region
    proven: BoolArray  # (R,) whether the region proves the pair's path SD_vis's
    radius: FloatArray  # (R,) the radius about its source of the region, cm
    hopped: NeighbourPairs  # the decaying pairs the proven paths hop over


def _searched_region(
    sweet: Neighbourhood,
    policy: str,
    ratio: float,
    source: IntArray,
    target: IntArray,
    margins: FloatArray,
    sight: JudgedSight,
    region: tuple[IntArray, IntArray],
) -> _Searched:
    """Search the pairs ``rows`` of the sources ``tile`` (``region``) in the region of the
    sources' balls (radii from ``margins``, which get each pair's next margin: a region's
    rows are its own)."""
    swarm, sensor, points = sweet.swarm, sweet.sensor, sweet.swarm.points
    tile, rows = region
    # Each source's radius: the widest its pairs need, one of a few steps.
    radius = _stepped(margins[rows])
    radius_of = np.zeros(swarm.size)
    np.maximum.at(radius_of, source[rows], radius)
    slack = _slack(points, tile, radius_of[tile])
    inside = slack >= 0.0
    longest = longest_edge(policy, ratio, swarm.radius, float(radius.max()))
    # A graph without the longer decaying pairs, or without the pairs no path of its
    # sources hops over, proves no pair apart.
    whole = longest >= sensor.decaying_max
    on_paths = None if whole else _OnPaths(policy, ratio, slack, swarm.radius)
    hood = _region(sweet, inside, sight, longest, on_paths)
    paths = shortest_paths(
        hood.any_visible, source[rows], target[rows], policy,
        components=hood.any_visible_components,
    )  # fmt: skip
    cost = paths.hops if policy == FEWEST_HOPS else paths.length
    spread = np.linalg.norm(points[target[rows]] - points[source[rows]], axis=1)
    mine = radius_of[source[rows]]
    needed = np.where(paths.found, (cost / ratio + spread) / 2.0, WIDER * mine)
    proven = paths.found & (needed <= mine)
    if whole:
        reach = max(sensor.sweet_max, sensor.decaying_max) + 2.0 * swarm.radius
        apart = ~paths.found & _closed(hood, inside, slack, source[rows], reach)
        proven |= apart | inside.all()
    hopped = _hopped(hood, paths.take(np.flatnonzero(proven)))
    # A path found in a region is no shorter than SD_vis's, often far longer (it went
    # round what the region lacked): a step wider, not the ball it needs.
    margins[rows] = np.maximum(np.minimum(needed, WIDER * mine), mine * (1.0 + 1e-9))
    return _Searched(rows, paths, proven, mine, hopped)


#: A group of sources is cut in two only where the halves' regions weigh at most this
#: many times the group's: where the sensor's reach spans the shape, each half holds
#: nearly the whole region, and cutting would build its pairs again for nothing.
MOST_OVERLAP = 1.5
#: A region weighing this many times the budget is cut however much its halves overlap,
#: if each half weighs less: sources spread over the shape with wide balls (paths of
#: 20 cm and more, the race car at 65,536 points) made regions of half the swarm.
OVERLOADED = 2.0
#: A source's radius is rounded up to a step of this ratio: a region is found by one
#: query of the FLSs per step, not per source, and holds the sources of one step.
RADIUS_STEP = 1.1
#: A pair its region did not join is searched again in a region this many times as wide.
#: Its path, if any, hops over a decaying pair longer than the region held, or its
#: ends lie apart; the first is the usual case, and needs a little more, where twice as
#: wide would hold nearly every decaying pair of the FLSs around it.
WIDER = 1.2


def _stepped(radii: FloatArray) -> FloatArray:
    """``radii``, cm, each rounded up to the next power of RADIUS_STEP."""
    steps = np.ceil(np.log(radii) / np.log(RADIUS_STEP) - 1e-9)
    return np.asarray(np.maximum(np.power(RADIUS_STEP, steps), radii), dtype=np.float64)


class _Weights:
    """Candidate pairs per FLS of a region, by the radius of its widest source: the
    swarm's mean, times the share of an FLS's pairs short enough for the region
    (:func:`longest_edge`) and not blind, counted round a seeded sample of the FLSs."""

    SAMPLE = 1000  # FLSs counted round

    def __init__(
        self, sweet: Neighbourhood, policy: str, ratio: float, candidates: IntArray
    ) -> None:
        swarm, self.sensor = sweet.swarm, sweet.sensor
        self.policy, self.ratio, self.fls_radius = policy, ratio, swarm.radius
        # (An FLS's own count is of the pairs it is first of, which depends on the order
        # of the indices: the mean, both ways, does not.)
        self.mean = 2.0 * float(candidates.sum()) / max(swarm.size, 1)
        # Here, not at import: its 0.1 s is for the runs that search decaying paths by region.
        from scipy.spatial import cKDTree

        self.tree = cKDTree(swarm.points)
        rows = np.random.default_rng(0).permutation(swarm.size)[: self.SAMPLE]
        self.sample = swarm.points[np.sort(rows)]
        self.every = self._within(sensor_reach(self.sensor, swarm.radius))
        # A region holds no blind pair (:func:`_region`): those weigh nothing.
        self.blind = self._within(self.sensor.sweet_min + 2.0 * swarm.radius)
        self.known: dict[float, float] = {}

    def _within(self, reach: float) -> int:
        return int(self.tree.query_ball_point(self.sample, reach, return_length=True).sum())

    def __call__(self, radius: float) -> float:
        if radius not in self.known:
            longest = longest_edge(self.policy, self.ratio, self.fls_radius, radius)
            within = self._within(sensor_reach(self.sensor, self.fls_radius, longest))
            self.known[radius] = self.mean * max(within - self.blind, 0) / max(self.every, 1)
        return self.known[radius]


def _tiles(
    points: FloatArray, sources: IntArray, margins: FloatArray, weights: _Weights, limit: int
) -> list[IntArray]:
    """The distinct ``sources`` in compact groups of one radius each, whose regions weigh
    at most ``limit`` candidates where cutting them smaller pays (``OVERLOADED`` times
    it where it does not), in k-d order.

    A group's region is every FLS within its source's radius of one of its sources: the
    largest of ``margins`` (one per entry of ``sources``) among that source's, stepped.
    """
    distinct, which = np.unique(sources, return_inverse=True)
    radius_of = np.zeros(len(distinct))
    np.maximum.at(radius_of, which, _stepped(margins))

    def weight(group: IntArray) -> float:
        """The group's region's FLSs at their candidates within its widest source's cut."""
        inside = _slack(points, distinct[group], radius_of[group]) >= 0.0
        return weights(float(radius_of[group].max())) * float(np.count_nonzero(inside))

    # Sources of one radius together: a region holds the decaying pairs its widest
    # source's paths may hop over (:func:`longest_edge`), so narrower ones would judge
    # longer pairs than they need.
    groups, todo = (
        [],
        [np.flatnonzero(radius_of == radius) for radius in np.unique(radius_of)[::-1]],
    )
    while todo:
        group = todo.pop()
        whole = weight(group)
        if len(group) > 1 and whole > limit:
            halves = [group[half] for half in kd_split(points[distinct[group]], 2)]
            parts = [weight(half) for half in halves]
            # Cut where it pays, and where the region would hold far more than the budget
            # and each half less: memory before time.
            pays = sum(parts) <= MOST_OVERLAP * whole
            if pays or (whole > OVERLOADED * limit and max(parts) < whole):
                todo.extend(reversed(halves))  # the first half is searched first
                continue
        groups.append(distinct[group])
    return groups


def _slack(points: FloatArray, centres: IntArray, radii: FloatArray) -> FloatArray:
    """How far inside the balls about the FLSs ``centres`` (their ``radii``, cm) each FLS
    lies: the largest radius less distance, cm; -inf where it is in none."""
    from scipy.spatial import cKDTree  # here, as in _Weights

    slack = np.full(len(points), -np.inf)
    for radius in np.unique(radii):
        bound = radius * 1.000001
        balls = points[centres[radii == radius]]
        # Only the FLSs in the balls' box are asked: a region is a small part of a display,
        # and a tree's query of every FLS cost most of a region's tiling (the same answers:
        # an FLS outside the box is in no ball).
        low, high = balls.min(axis=0) - bound, balls.max(axis=0) + bound
        near = np.flatnonzero(np.all((points >= low) & (points <= high), axis=1))
        distance, _ = cKDTree(balls).query(points[near], distance_upper_bound=bound)
        slack[near] = np.maximum(slack[near], radius - distance)
    return slack


@dataclass(frozen=True)
class _OnPaths:
    """Which pairs of a region can be hops of its sources' paths (:func:`longest_edge`).

    An edge u-v of cost w on a path from s that its region proves satisfies
    ``|s - u| + |s - v| + w / ratio <= 2 R``, R the source's radius. With
    ``slack`` each FLS's largest ``R - |s - u|`` over the region's sources
    (:func:`_slack`), ``slack[u] + slack[v] >= w / ratio`` holds for every such
    edge: pairs that fail it are on no path the region can prove. With one
    source the test is exact; sources spread over the shape with wide balls
    keep only the pairs near each of them.
    """

    policy: str
    ratio: float
    slack: FloatArray  # (N,) cm, -inf outside the region
    fls_radius: float  # r, cm

    def affordable(self, members: IntArray) -> Affordable:
        """The test for the swarm of the FLSs ``members``, as :func:`.neighbours.neighbour_pairs`
        takes it: a pair's cost over ``ratio`` against its ends' slack."""
        # A hair more slack for rounding (``ratio`` is a hair low): keeping a pair more is safe.
        spare = self.slack[members] * (1.0 + 1e-7) + 1e-7
        if self.policy == FEWEST_HOPS:
            return Affordable(spare, 0.0, 1.0 / self.ratio)
        # Shortest-length: the tracking distance, d - 2r.
        return Affordable(spare, 1.0 / self.ratio, -2.0 * self.fls_radius / self.ratio)


def _region(
    sweet: Neighbourhood,
    inside: BoolArray,
    sight: JudgedSight,
    longest: float,
    on_paths: _OnPaths | None,
) -> Neighbourhood:
    """The sweet pairs and the decaying pairs shorter than ``longest`` (tracking distance,
    cm) with both FLSs ``inside``, those of them ``on_paths`` where given, and their sight
    (the decaying pairs' judged once, in ``sight``), as a neighbourhood."""
    swarm, sensor = sweet.swarm, sweet.sensor
    # The region's FLSs as a swarm of their own: its pairs are the whole list's pairs between
    # them, each distance from the same two points, found without the pairs that leave it.
    members = np.flatnonzero(inside)
    part = replace(swarm, points=swarm.points[members], cloud_index=swarm.cloud_index[members])
    # The sweet pairs too (their sight is known), however short the decaying pairs are cut;
    # with ``on_paths``, sweet and decaying, only those near enough a source.
    affordable = EVERY_PAIR if on_paths is None else on_paths.affordable(members)
    # No blind pair: none is a hop, and they were a quarter of those within reach.
    found = neighbour_pairs(
        part,
        sensor,
        longest=max(longest, sensor.sweet_max),
        affordable=affordable,
        shortest=sensor.sweet_min,
    )
    hops = (found.range_class == SWEET) | (found.range_class == DECAYING)
    if not hops.all():  # a sensor's gap between sweet and decaying
        found = found.select(hops)
    pairs = replace(found, first=members[found.first], second=members[found.second])
    visible = np.zeros(len(pairs), dtype=bool)
    is_sweet = pairs.range_class == SWEET
    # The sweet pairs' sight is known; the decaying pairs' is judged as the whole graph's is.
    known = sweet.pairs.index(pairs.first[is_sweet], pairs.second[is_sweet])
    visible[is_sweet] = sweet.visible[known]
    decaying = ~is_sweet
    visible[decaying] = sight.of(swarm, sweet.grid, pairs.first[decaying], pairs.second[decaying])
    usable = np.ones(len(pairs), dtype=bool)
    return Neighbourhood(swarm, sensor, pairs, visible, sweet.grid, usable)


def _closed(
    hood: Neighbourhood, inside: BoolArray, slack: FloatArray, sources: IntArray, reach: float
) -> BoolArray:
    """Whether each source's part of the region's SD_vis lies ``reach`` inside the balls
    that make the region (``slack``, :func:`_slack`): no edge of SD_vis can then leave
    it, so the part is the source's whole part."""
    parts = hood.any_visible_components
    members = np.flatnonzero(inside)
    labels = parts[members]
    least = np.full(int(labels.max()) + 1 if len(labels) else 0, np.inf)
    np.minimum.at(least, labels, slack[members])
    return np.asarray(least[parts[sources]] >= reach)


def _hopped(hood: Neighbourhood, paths: Paths) -> NeighbourPairs:
    """The decaying pairs of ``hood`` that ``paths`` hop over (repeats kept)."""
    _, start, end = path_hops(paths)
    records = hood.pairs.select(hood.pairs.index(start, end))
    return records.select(records.range_class == DECAYING)


def _in_order(size: int, kept: list[tuple[IntArray, Paths]]) -> Paths:
    """The ``size`` pairs' paths, each taken from the part of ``kept`` that proved it."""
    if not kept:
        none = np.zeros(0, dtype=np.int64)
        return Paths(np.zeros(0, dtype=bool), none, np.zeros(0), np.zeros(1, dtype=np.int64), none)
    rows = np.concatenate([part for part, _ in kept])
    if len(rows) != size or len(np.unique(rows)) != size:
        raise RuntimeError("every pair is proven once")
    counts = np.concatenate([np.diff(paths.offsets) for _, paths in kept])
    nodes = np.concatenate([paths.nodes for _, paths in kept])
    order = np.argsort(rows, kind="stable")
    offsets, nodes = csr.take(csr.offsets(counts), nodes, order)
    found = np.concatenate([paths.found for _, paths in kept])[order]
    hops = np.concatenate([paths.hops for _, paths in kept])[order]
    length = np.concatenate([paths.length for _, paths in kept])[order]
    return Paths(found, hops, length, offsets, nodes)


def _sorted_once(parts: list[NeighbourPairs]) -> NeighbourPairs:
    """The pairs of ``parts`` sorted by (first, second), each once."""
    if not parts:
        ints, reals = np.zeros(0, dtype=np.int64), np.zeros(0)
        return NeighbourPairs(ints, ints, reals, reals, np.zeros(0, dtype=np.int8))
    joined = NeighbourPairs.joined(parts)
    size = int(max(joined.first.max(initial=0), joined.second.max(initial=0))) + 1
    _, once = np.unique(joined.first * size + joined.second, return_index=True)
    return joined.select(once)
