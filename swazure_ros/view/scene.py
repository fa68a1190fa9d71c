"""The swarm as a scene: spheres coloured by a status, paths as polylines, moves as arrows.

One scene feeds every picture of the swarm: the PNG snapshot (``snapshot``),
RViz's MarkerArray and Foxglove's SceneUpdate (``ros.convert``). Colours are
RGBA in [0, 1]; positions are cm in the swarm frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray
from ..core.errors import SwazureError, UnknownFlsError
from ..core.evaluation import SWEET_PATH, Evaluation
from ..core.frames import SWARM_FRAME
from ..core.heuristics.result import HeuristicResult
from ..core.neighbourhood import Neighbourhood
from ..core.sensor import BLIND, DECAYING, SWEET

#: The frame the viewers draw the scene in.
SCENE_FRAME = SWARM_FRAME
Colour = tuple[float, float, float, float]
#: A label and its RGBA colour.
LegendEntry = tuple[str, Colour]

#: Share of an FLS's blind neighbours whose pose it has by a sweet path -> (label, RGBA),
#: from the lowest share up: the bins of :func:`status_colours`.
SWEET_SHARE_BINS = (
    (0.0, "under 25 % by a sweet path", (0.84, 0.15, 0.16, 1.0)),
    (0.25, "25 % or more", (1.0, 0.5, 0.05, 1.0)),
    (0.5, "50 % or more", (0.74, 0.74, 0.13, 1.0)),
    (0.75, "75 % or more", (0.18, 0.63, 0.17, 1.0)),
)
NO_BLIND = ("no blind neighbour", (0.7, 0.7, 0.7, 0.35))
#: Range class of a neighbour of the chosen FLS -> (label, RGBA).
RANGE_COLOURS = {
    BLIND: ("blind", (0.84, 0.15, 0.16, 1.0)),
    SWEET: ("sweet", (0.18, 0.63, 0.17, 1.0)),
    DECAYING: ("decaying", (1.0, 0.6, 0.0, 1.0)),
}
CHOSEN = ("the chosen FLS", (0.12, 0.47, 0.71, 1.0))
OTHER = ("out of range", (0.7, 0.7, 0.7, 0.35))
PATH_COLOURS = ((0.12, 0.47, 0.71, 1.0), (0.58, 0.4, 0.74, 1.0), (0.0, 0.0, 0.0, 1.0))
PATH_COLOUR = PATH_COLOURS[0]
MOVE_COLOUR = (0.55, 0.34, 0.29, 1.0)


@dataclass(frozen=True)
class Polyline:
    """A path through FLS centres (K, 3), cm, with what it is."""

    points: FloatArray
    label: str
    colour: Colour = PATH_COLOUR


@dataclass(frozen=True)
class Scene:
    """What a view of the swarm shows."""

    title: str
    ids: NDArray[np.int64]  # (N,) FLS ids
    points: FloatArray  # (N, 3), cm
    radius: float  # cm
    colours: FloatArray  # (N, 4) RGBA
    legend: list[LegendEntry]
    paths: list[Polyline] = field(default_factory=list)
    moves: list[tuple[FloatArray, FloatArray]] = field(default_factory=list)  # (3,), (3,) cm
    highlight: int | None = None  # index of the FLS the colours are seen from


def status_colours(evaluation: Evaluation) -> tuple[FloatArray, list[LegendEntry]]:
    """(N, 4) each FLS's colour by the share of its blind neighbours it has by a sweet path.

    The legend says how many FLSs fall in each bin of SWEET_SHARE_BINS.
    """
    size = evaluation.hood.swarm.size
    pairs = evaluation.pairs
    blind = np.bincount(pairs.source, minlength=size)
    sweet = np.bincount(pairs.source[pairs.status == SWEET_PATH], minlength=size)
    share = np.divide(sweet, blind, out=np.zeros(size), where=blind > 0)
    colours = np.tile(np.array(NO_BLIND[1]), (size, 1))
    legend = []
    bins = np.searchsorted([low for low, _, _ in SWEET_SHARE_BINS], share, side="right") - 1
    for index, (_, label, colour) in enumerate(SWEET_SHARE_BINS):
        here = (bins == index) & (blind > 0)
        colours[here] = colour
        legend.append((f"{label} ({int(here.sum())} FLSs)", colour))
    legend.append((f"{NO_BLIND[0]} ({int((blind == 0).sum())} FLSs)", NO_BLIND[1]))
    return colours, legend


def range_colours(hood: Neighbourhood, chosen: int) -> tuple[FloatArray, list[LegendEntry]]:
    """(N, 4) colours by the range class of each FLS seen from FLS index ``chosen``."""
    colours = np.tile(np.array(OTHER[1]), (hood.swarm.size, 1))
    pairs = hood.pairs
    mine = (pairs.first == chosen) | (pairs.second == chosen)
    other = np.where(pairs.first[mine] == chosen, pairs.second[mine], pairs.first[mine])
    kinds = pairs.range_class[mine]
    legend = [(CHOSEN[0], CHOSEN[1])]
    for kind, (label, colour) in RANGE_COLOURS.items():
        colours[other[kinds == kind]] = colour
        legend.append((f"{label} ({int((kinds == kind).sum())})", colour))
    colours[chosen] = CHOSEN[1]
    legend.append((OTHER[0], OTHER[1]))
    return colours, legend


def example_paths(
    evaluation: Evaluation, count: int = 3, source: int | None = None
) -> list[Polyline]:
    """Sweet paths of ``count`` hop counts spread from the fewest to the most.

    The hop counts are the sweet paths' quantiles 0 to 1 (distinct ones);
    of the pairs with a count, the lowest source id and then target id.
    With ``source`` (a swarm index), that FLS's paths only.
    """
    pairs = evaluation.pairs
    swarm = evaluation.hood.swarm
    ids = swarm.cloud_index
    found = (pairs.status == SWEET_PATH) & (pairs.hops >= 2)
    if source is not None:
        found &= pairs.source == source
    found = np.flatnonzero(found)
    if not len(found) or count < 1:
        return []
    wanted = np.unique(np.quantile(pairs.hops[found], np.linspace(0, 1, count), method="nearest"))
    chosen: list[Polyline] = []
    for hops in wanted:
        these = found[pairs.hops[found] == hops]
        pair = these[np.lexsort((ids[pairs.target[these]], ids[pairs.source[these]]))[0]]
        nodes = pairs.nodes[pairs.offsets[pair] : pairs.offsets[pair + 1]]
        label = f"FLS {ids[pairs.source[pair]]} -> {ids[pairs.target[pair]]}, {int(hops)} hops"
        colour = PATH_COLOURS[len(chosen) % len(PATH_COLOURS)]
        chosen.append(Polyline(swarm.points[nodes].copy(), label, colour))
    return chosen


def pair_paths(evaluation: Evaluation, pairs: Sequence[tuple[int, int]]) -> list[Polyline]:
    """The paths of the ordered blind pairs ``pairs`` (source id, target id), as found.

    A pair without a path is left out; SwazureError names a pair that is not
    an ordered blind pair of the evaluation.
    """
    results = evaluation.pairs
    ids = evaluation.hood.swarm.cloud_index
    points = evaluation.hood.swarm.points
    chosen: list[Polyline] = []
    for source, target in pairs:
        rows = np.flatnonzero((ids[results.source] == source) & (ids[results.target] == target))
        if not len(rows):
            raise SwazureError(f"FLS {source} -> {target} is not a blind pair of this swarm")
        pair = int(rows[0])
        nodes = results.nodes[results.offsets[pair] : results.offsets[pair + 1]]
        if len(nodes) < 2:
            continue
        label = f"FLS {source} -> {target}, {int(results.hops[pair])} hops"
        colour = PATH_COLOURS[len(chosen) % len(PATH_COLOURS)]
        chosen.append(Polyline(points[nodes].copy(), label, colour))
    return chosen


def example_moves(
    heuristic: HeuristicResult | None, pairs: int = 3
) -> list[tuple[FloatArray, FloatArray]]:
    """The moves (from, to), cm, that resolved the first ``pairs`` resolved pairs."""
    if heuristic is None:
        return []
    moves = []
    for pair in np.flatnonzero(heuristic.resolved)[:pairs]:
        moves += [(start, end) for _, start, end in heuristic.moves(int(pair))]
    return moves


def evaluation_scene(
    evaluation: Evaluation,
    title: str,
    colour_by: str = "status",
    seen_from: int | None = None,
    paths: int = 3,
    heuristic: HeuristicResult | None = None,
    pairs: Sequence[tuple[int, int]] = (),
) -> Scene:
    """The scene of one evaluation, coloured by ``colour_by``.

    "status": each FLS by the share of its blind neighbours it has by a sweet
    path, with example paths of the swarm; "ranges": each FLS by its range
    class seen from FLS ``seen_from`` (an id; default the first), with
    example paths from it. With ``heuristic``, the moves of a few resolved pairs.
    With ``pairs`` (source id, target id), those pairs' paths instead of examples.
    """
    swarm = evaluation.hood.swarm
    if colour_by == "status":
        colours, legend = status_colours(evaluation)
        return Scene(
            title,
            swarm.cloud_index.copy(),
            swarm.points.copy(),
            float(swarm.radius),
            colours,
            legend,
            pair_paths(evaluation, pairs) if pairs else example_paths(evaluation, paths),
            example_moves(heuristic),
        )
    if colour_by != "ranges":
        raise SwazureError(f"unknown colouring {colour_by!r}: status or ranges")
    scene = ranges_scene(evaluation.hood, title, seen_from)
    return replace(
        scene,
        paths=pair_paths(evaluation, pairs)
        if pairs
        else example_paths(evaluation, paths, source=scene.highlight),
        moves=example_moves(heuristic),
    )


def ranges_scene(hood: Neighbourhood, title: str, seen_from: int | None = None) -> Scene:
    """Every FLS coloured by its range class seen from FLS ``seen_from`` (default the first)."""
    swarm = hood.swarm
    ids = swarm.cloud_index
    chosen = int(ids[0]) if seen_from is None else seen_from
    index = int(np.searchsorted(ids, chosen))
    if index >= len(ids) or ids[index] != chosen:
        raise UnknownFlsError(f"no FLS {chosen} in this swarm of {len(ids)} FLSs")
    colours, legend = range_colours(hood, index)
    legend[0] = (f"FLS {chosen}", legend[0][1])
    return Scene(
        title, ids.copy(), swarm.points.copy(), float(swarm.radius), colours, legend,
        highlight=index,
    )  # fmt: skip


def placed(scene: Scene, home: FloatArray, ids: NDArray[np.int64], points: FloatArray) -> Scene:
    """``scene`` with FLSs ``ids`` (K,) at ``points`` (K, 3), cm; an arrow per FLS off ``home``."""
    rows = np.searchsorted(scene.ids, ids)
    known = (rows < len(scene.ids)) & (scene.ids[np.minimum(rows, len(scene.ids) - 1)] == ids)
    now = scene.points.copy()
    now[rows[known]] = points[known]
    away = np.flatnonzero((now != home).any(axis=1))
    return replace(scene, points=now, moves=[(home[i], now[i]) for i in away])
