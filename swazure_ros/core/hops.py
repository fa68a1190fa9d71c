"""What the hops of many paths measure: their pairs, vectors, sums, classes and obstruction.

A :class:`HopTable` lists every hop of M paths once, with the pair of the
neighbourhood it crosses; :func:`estimates` sums each path's measured hop
vectors (the paper's estimate), :func:`summed_hop_errors` its hops'
expected errors, :func:`hop_classes` counts its sweet and decaying hops and
:func:`path_obstruction` says which paths have an obstructed hop and by how
many FLSs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import csr, jit
from .arrays import FloatArray, IntArray
from .distinct import distinct_ranks
from .graph import Graph
from .hop_errors import hop_error, measured_vectors
from .neighbourhood import Neighbourhood
from .path_arrays import Paths, path_hops
from .sensor import DECAYING, SWEET
from .sight import obstructers


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
    """Every hop of M paths, each with its pair in the neighbourhood.

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    paths : Paths
        M paths whose every hop joins two FLSs within reach (a pair of ``hood.pairs``).

    Returns
    -------
    HopTable
        H hops, path after path, each path's from its source on; ``slot`` is
        the hop's place in SD_vis, -1 for a hop out of sight.

    Raises
    ------
    ValueError
        A path hops between FLSs out of each other's reach.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> hops = hop_table(hood, paths)
    >>> hops.path.tolist(), hops.start.tolist(), hops.end.tolist()
    ([0, 0], [0, 1], [1, 2])
    >>> hops.slot.tolist()  # the fourth FLS blocks A-B: not an edge of SD_vis
    [-1, 0]
    """
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
    """The measured vector of every hop, each directed edge of SD_vis measured once.

    However many paths cross an edge of SD_vis, it is measured once; a hop
    out of sight is measured on its own. A pair's two directions are two
    measurements (a noisy sensor draws per direction).

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    hops : HopTable
        H hops of M paths (:func:`hop_table`).

    Returns
    -------
    vectors : (K, 3) ndarray of float, cm
        The distinct measurements, each from the hop's start to its end.
    rows : (H,) ndarray of int
        The row of ``vectors`` of each hop.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> vectors, rows = hop_vectors(hood, hop_table(hood, paths))
    >>> vectors.shape, rows.tolist()
    ((2, 3), [1, 0])
    """
    swarm, sensor, graph = hood.swarm, hood.sensor, hood.any_visible
    on_graph = hops.slot >= 0
    # A pair's two directions are two measurements (a noisy sensor draws per direction).
    # A block of a display's pairs crosses a sliver of SD_vis's slots (47 M at 30,000 FLSs),
    # a whole swarm's block most of them: distinct_ranks decides how to find them.
    slots, slot_rows = distinct_ranks(hops.slot[on_graph], len(graph.indices))
    leaves = np.searchsorted(graph.indptr, slots, side="right") - 1
    once = measured_vectors(sensor, swarm.points, swarm.radius, leaves, graph.indices[slots])
    if on_graph.all():
        return once, slot_rows
    off = np.flatnonzero(~on_graph)
    rows = np.empty(len(hops.slot), dtype=np.int64)
    rows[on_graph] = slot_rows
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
    """Each path's estimate: its measured hop vectors summed from the source outwards.

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    paths : Paths
        M paths whose every hop joins two FLSs within reach (a pair of ``hood.pairs``).
    hops : HopTable, optional
        ``hop_table(hood, paths)``, when the caller has it.

    Returns
    -------
    estimate : (M, 3) ndarray of float, cm
        From the path's source to its target; NaN without a path.
    sweet_hops, decaying_hops : (M,) ndarray of int
        The path's sweet and decaying hops.

    Raises
    ------
    ValueError
        A path hops between FLSs out of each other's reach.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> estimate, sweet, decaying = estimates(hood, paths)
    >>> np.round(estimate, 1).tolist(), sweet.tolist(), decaying.tolist()
    ([[4.0, 0.0, 0.0], [nan, nan, nan]], [2, 0], [0, 0])
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
    """Each path's sum of its hops' expected errors (:func:`~.hop_errors.hop_error`).

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    paths : Paths
        M paths whose every hop joins two FLSs within reach (a pair of ``hood.pairs``).
    hops : HopTable, optional
        ``hop_table(hood, paths)``, when the caller has it.

    Returns
    -------
    (M,) ndarray of float, cm
        NaN without a path.

    Raises
    ------
    ValueError
        A path hops between FLSs out of each other's reach.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> np.round(summed_hop_errors(hood, paths), 3).tolist()
    [0.175, nan]
    """
    hops = hops or hop_table(hood, paths)
    costs = hop_error(hood.sensor, hood.pairs.tracking[hops.pair], hood.swarm.radius)
    return np.where(paths.found, hops.sums(costs), np.nan)


def hop_classes(
    hood: Neighbourhood, paths: Paths, hops: HopTable | None = None
) -> tuple[IntArray, IntArray]:
    """The sweet and the decaying hops of each path.

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    paths : Paths
        M paths whose every hop joins two FLSs within reach (a pair of ``hood.pairs``).
    hops : HopTable, optional
        ``hop_table(hood, paths)``, when the caller has it.

    Returns
    -------
    sweet_hops, decaying_hops : (M,) ndarray of int
        0 and 0 without a path.

    Raises
    ------
    ValueError
        A path hops between FLSs out of each other's reach.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> [counts.tolist() for counts in hop_classes(hood, paths)]
    [[2, 0], [0, 0]]
    """
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
    """Whether each path has a hop out of sight, and how many FLSs obstruct its hops.

    Each obstructed pair's obstructing FLSs are found once, however many
    paths cross it; an FLS that obstructs two hops of a path counts once.

    Parameters
    ----------
    hood : Neighbourhood
        The neighbourhood the paths run in.
    graph : Graph
        A graph of ``hood`` whose edges hold every hop of ``paths`` (S_all for
        the policy's sweet paths).
    paths : Paths
        M paths in ``graph``.

    Returns
    -------
    obstructed : (M,) ndarray of bool
        The path has a hop out of sight.
    obstructing_flss : (M,) ndarray of int
        The distinct FLSs that obstruct its hops.

    Raises
    ------
    ValueError
        A path hops between FLSs that ``graph`` does not join.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.path_arrays import paths_from_rows
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [1, 3.5, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> paths = paths_from_rows(2, {0: [0, 1, 2]})  # A-B-C; pair 1 has no path
    >>> blocked, obstructing = path_obstruction(hood, hood.sweet_all, paths)
    >>> blocked.tolist(), obstructing.tolist()
    ([True, False], [1, 0])
    """
    size = len(paths.found)
    pair, start, end = path_hops(paths)
    hop_pair = graph.edge_labels(start, end)
    if np.any(hop_pair < 0):
        raise ValueError("a path hops between FLSs that `graph` does not join")
    blocked = ~hood.visible[hop_pair]
    has_obstruction = np.bincount(pair[blocked], minlength=size) > 0
    # Each blocked pair's obstructers are found once, however many paths cross it.
    edges, edge_of_blocked_hop = distinct_ranks(hop_pair[blocked], len(hood.pairs))
    swarm = hood.swarm
    offsets, ids = obstructers(
        swarm.points, swarm.radius, hood.pairs.first[edges], hood.pairs.second[edges], hood.grid
    )
    hop_edge = np.full(len(pair), -1, dtype=np.int64)
    hop_edge[blocked] = edge_of_blocked_hop
    hop_offsets = csr.offsets(np.bincount(pair, minlength=size))
    distinct = _distinct_per_path(hop_offsets.astype(np.int64), hop_edge, offsets, ids)
    return has_obstruction, np.asarray(distinct)
