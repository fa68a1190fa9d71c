"""The swarm's move schedule: which of a heuristic's moves a swarm makes together.

A coordinator that makes a heuristic's moves for real sends them in batches
(:func:`move_batches`): moves whose paths cannot meet go out together.
:func:`walked` replaces the engine's planned estimates by what the swarm's
path walks measured.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..core import jit
from ..core.arrays import FloatArray, IntArray
from ..core.evaluation import Evaluation
from ..core.heuristics.obstructing import TOUCH
from ..core.heuristics.result import HeuristicResult
from ..core.segments import near_any_segment


@jit.kernel(cache=True, nogil=True)
def _closer_than(first: FloatArray, second: FloatArray, distance: float) -> bool:
    """True when a point of ``first`` (K, 3) is closer than ``distance`` to one of ``second``."""
    for k in range(len(first)):
        for m in range(len(second)):
            gx, gy = first[k, 0] - second[m, 0], first[k, 1] - second[m, 1]
            gz = first[k, 2] - second[m, 2]
            if np.sqrt(gx * gx + gy * gy + gz * gz) < distance:
                return True
    return False


@dataclass
class _Batch:
    pairs: list[int]
    moved: dict[int, tuple[float, float, float]]  # FLS -> where it moves to, cm
    starts: list[FloatArray]  # hop segments of the batch's paths, (H, 3) per pair, cm
    ends: list[FloatArray]
    _arrays: tuple[IntArray, FloatArray, FloatArray, FloatArray] | None = None

    def arrays(self) -> tuple[IntArray, FloatArray, FloatArray, FloatArray]:
        """Moved FLSs (M,), where they go (M, 3), hop starts and ends (S, 3) each, cm."""
        # Cached: a batch is looked at by many pairs between two that join it.
        if self._arrays is None:
            self._arrays = (
                np.fromiter(self.moved, dtype=np.int64, count=len(self.moved)),
                np.array(list(self.moved.values()), dtype=np.float64).reshape(-1, 3),
                np.concatenate(self.starts) if self.starts else np.zeros((0, 3)),
                np.concatenate(self.ends) if self.ends else np.zeros((0, 3)),
            )
        return self._arrays

    def join(
        self, pair: int, moved: dict[int, tuple[float, float, float]], where: FloatArray
    ) -> None:
        """Add ``pair``, its moves and its hops between ``where`` (H + 1, 3), cm."""
        self.pairs.append(pair)
        self.moved.update(moved)
        self.starts.append(where[:-1])
        self.ends.append(where[1:])
        self._arrays = None


def move_batches(evaluation: Evaluation, heuristic: HeuristicResult) -> list[IntArray]:
    """A heuristic's resolved pairs in groups whose moves can be made at once.

    A pair joins the first group (in pair order) where no FLS it moves goes
    elsewhere for another pair or lies on another pair's path, no FLS on its
    path moves for another pair, no FLS moved by the group stands within r
    of a hop of another pair, and no two FLSs moved for different pairs come
    closer than 2r. Hops run between where the path's FLSs stand once the
    pair's moves are made (Move Source's source at its probe position). Every
    pair of a group then sees its hops exactly as it would alone: its own
    moves made, nothing new in sight.
    """
    points, radius = evaluation.hood.swarm.points, evaluation.hood.swarm.radius
    paths = heuristic.paths
    batches: list[_Batch] = []
    # Per FLS and batch: does it lie on a path of the batch, and where does it move
    # in the batch (an index into its destinations; -1: it stays). A pair's
    # conflicts by FLS are then a few rows of these tables, not a look into every batch.
    capacity = 64
    on_path = np.zeros((len(points), capacity), dtype=bool)
    moves_to = np.full((len(points), capacity), -1, dtype=np.int32)
    destinations: list[dict[tuple[float, float, float], int]] = [{} for _ in points]
    is_mover = np.zeros(len(points), dtype=bool)  # the FLSs the pair at hand moves
    for pair in np.flatnonzero(heuristic.resolved).tolist():
        path = paths.nodes[paths.offsets[pair] : paths.offsets[pair + 1]]
        moved: dict[int, tuple[float, float, float]] = {
            fls: (float(to[0]), float(to[1]), float(to[2])) for fls, _, to in heuristic.moves(pair)
        }
        where = np.array([moved.get(fls, points[fls]) for fls in path.tolist()], dtype=np.float64)
        starts, ends = where[:-1], where[1:]
        count = len(batches)
        excluded = (moves_to[path, :count] >= 0).any(axis=0)
        movers = np.fromiter(moved, dtype=np.int64, count=len(moved))
        is_mover[movers] = True
        if len(movers):
            going_to = np.array(
                [
                    destinations[fls].setdefault(to, len(destinations[fls]))
                    for fls, to in moved.items()
                ]
            )
            elsewhere = moves_to[movers, :count]
            excluded |= on_path[movers, :count].any(axis=0)
            excluded |= ((elsewhere >= 0) & (elsewhere != going_to[:, None])).any(axis=0)
        destination = np.array(list(moved.values()), dtype=np.float64).reshape(-1, 3)
        for index in np.flatnonzero(~excluded).tolist():
            batch = batches[index]
            ids, goes_to, batch_starts, batch_ends = batch.arrays()
            mine = destination[moves_to[movers, index] < 0]
            theirs = goes_to[~is_mover[ids]]
            # Compiled, and each check stops at its first conflict: most candidate
            # batches of a pair conflict, and this loop is most of the planning.
            if (
                _closer_than(mine, theirs, 2.0 * radius)
                or near_any_segment(mine, batch_starts, batch_ends, radius - TOUCH)
                or near_any_segment(theirs, starts, ends, radius - TOUCH)
            ):
                continue
            break
        else:
            index, batch = count, _Batch([], {}, [], [])
            batches.append(batch)
            if count == capacity:
                capacity *= 2
                on_path = np.pad(on_path, ((0, 0), (0, capacity - count)))
                moves_to = np.pad(moves_to, ((0, 0), (0, capacity - count)), constant_values=-1)
        is_mover[movers] = False
        batch.join(pair, moved, where)
        on_path[path, index] = True
        for fls, to in moved.items():
            moves_to[fls, index] = destinations[fls][to]
    return [np.array(batch.pairs, dtype=np.int64) for batch in batches]


def walked(heuristic: HeuristicResult, vectors: dict[int, FloatArray]) -> HeuristicResult:
    """``heuristic`` with its resolved pairs re-measured: {pair: summed vector (3,), cm}.

    A resolved pair whose path walk did not arrive is not resolved after all.
    """
    arrived = np.zeros(len(heuristic.resolved), dtype=bool)
    arrived[list(vectors)] = True
    resolved = heuristic.resolved & arrived
    estimate = np.full_like(heuristic.estimate, np.nan)
    for pair in np.flatnonzero(resolved).tolist():
        estimate[pair] = vectors[pair]
    truth = np.where(resolved[:, None], heuristic.truth, np.nan)
    return replace(heuristic, resolved=resolved, estimate=estimate, truth=truth)
