"""Radio cells: the swarm's space cut into cubes no smaller than the radio's reach.

An FLS broadcasts on the topic of the cell that holds it and hears its own
cell and the 26 around it. Every FLS within radio reach of it lies in one of
those 27 cells (two points closer than a cell's edge differ by at most one
cell along each axis), so it hears every broadcast a real radio would bring
it, and a process hears nothing of the FLSs far from its own. The cells are
fixed in space (the origin is every axis's zero), so that every process, the
coordinator and a person echoing a topic agree on them without asking.

Two bands of cells: in the sweet phases (S_vis, S_all) an FLS relays from
its sweet neighbours only, within the sweet range, so those offers travel in
``sweet`` cells of the sweet reach; the SD_vis phase's relay from decaying
neighbours too, in ``decaying`` cells of the sensor's whole reach. With the
published sensor the first are 3.5 times smaller along each axis.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.lookup import sorted_rows
from ..core.neighbours import sensor_reach
from ..core.sensor import Sensor
from .discovery.messages import ANY_VISIBLE, FIT

#: The 27 offsets (27, 3) from a cell to the cells around it, itself included.
AROUND = np.array(
    [(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)], dtype=np.int64
)
#: A cell's edge is the radio's reach times this: a reach computed in another order of
#: floating-point operations must not straddle two cells apart.
MARGIN = 1.0 + 1e-9


@dataclass(frozen=True)
class Cells:
    """Cubic cells of edge ``size`` cm, cell (i, j, k) holding [i, i + 1) * size along x, ..."""

    size: float

    def __post_init__(self) -> None:
        if not 0.0 < self.size < float("inf"):
            raise ValueError(f"a cell's edge must be a number of cm > 0, got {self.size}")

    def of(self, points: FloatArray) -> IntArray:
        """(N, 3) the cell of each point of ``points`` (N, 3), cm."""
        return np.floor(np.asarray(points, dtype=np.float64) / self.size).astype(np.int64)

    def around(self, cells: IntArray) -> IntArray:
        """(M, 3) the cells within one step of any of ``cells`` (K, 3), each once, sorted."""
        near = (np.asarray(cells, dtype=np.int64).reshape(-1, 1, 3) + AROUND).reshape(-1, 3)
        return np.unique(near, axis=0)

    def heard_by(self, listeners: FloatArray, points: FloatArray) -> NDArray[np.bool_]:
        """(N,) which of ``points`` (N, 3) lie in the cells that ``listeners`` (K, 3) hear."""
        heard = {tuple(cell) for cell in self.around(self.of(listeners)).tolist()}
        return np.array([tuple(cell) in heard for cell in self.of(points).tolist()], dtype=bool)


#: The bands of cells: the sweet phases' offers, and the SD_vis phase's.
SWEET_BAND, DECAYING_BAND = "sweet", "decaying"
BANDS = (SWEET_BAND, DECAYING_BAND)


def band_of(phase: int) -> str:
    """The band of cells that carries the offers of discovery phase ``phase``."""
    # The swarm's fit is heard by every FLS an FLS measures, decaying hops' ends included.
    return DECAYING_BAND if phase in (ANY_VISIBLE, FIT) else SWEET_BAND


def radio_cells(sensor: Sensor, radius: float) -> dict[str, Cells]:
    """Per band, the cells of a swarm of FLSs of ``radius`` cm that measure with ``sensor``."""
    reach = sensor_reach(sensor, radius)
    sweet = min(max(sensor.sweet_max + 2.0 * radius, 2.0 * radius), reach)
    return {SWEET_BAND: Cells(sweet * MARGIN), DECAYING_BAND: Cells(reach * MARGIN)}


def cell_name(cell: Sequence[int] | IntArray) -> str:
    """A cell as a name token: (3, -1, 0) -> ``c3_m1_0`` (no sign, no leading digit)."""
    return "c" + "_".join(f"m{-int(i)}" if i < 0 else str(int(i)) for i in cell)


#: A radio cell of one band: (band, i, j, k).
Cell = tuple[str | int, ...]


#: Cell indices as one int64 key each (:func:`_keys`): each index shifted by this and
#: given 21 bits, which holds cells of any swarm within 10 km of the origin.
_SHIFT = 1 << 20


def _keys(cells: IntArray) -> IntArray:
    """(K,) an int64 key of each cell (K, 3), ordered as the cells are lexicographically."""
    shifted = np.asarray(cells, dtype=np.int64) + _SHIFT
    return (shifted[:, 0] << 42) | (shifted[:, 1] << 21) | shifted[:, 2]


#: The keys of AROUND's offsets: a cell's key plus one is the key of that neighbour
#: (each index is a field of its own, well inside its bits).
_OFFSET_KEYS = _keys(AROUND) - _keys(np.zeros((1, 3), dtype=np.int64))


def _cells_of_keys(band: str, keys: IntArray) -> set[Cell]:
    """The cells (band, i, j, k) of ``keys``."""
    mask = (1 << 21) - 1
    indices = np.stack([keys >> 42, (keys >> 21) & mask, keys & mask], axis=1) - _SHIFT
    return {(band, *cell) for cell in indices.tolist()}


@dataclass(frozen=True)
class Tuning:
    """What a process's radio hears and sends on, its FLSs and the others where they are."""

    mine: frozenset[Cell]  # the cells its FLSs are in: it sends on them
    heard: frozenset[Cell]  # the cells around its FLSs that hold another process's FLS
    audible: dict[str, IntArray]  # per band, the ids of the FLSs in the cells around its own
    local: IntArray  # (L,) its FLSs' ids, sorted
    placed: dict[str, IntArray]  # per band, (L, 3) the cell of each of its FLSs

    def cell_of(self, band: str, fls_id: int) -> Cell | None:
        """The cell of ``band`` that holds its FLS ``fls_id``; None if not one of its FLSs."""
        return self.cells_of(band, np.array([fls_id], dtype=np.int64))[0]

    def _rows_of(self, fls_ids: IntArray) -> tuple[IntArray, NDArray[np.bool_]]:
        """(M,) the row of each of ``fls_ids`` in :attr:`local`, and whether it is there."""
        return sorted_rows(self.local, fls_ids)

    def rows_by_cell(
        self, band: str, fls_ids: IntArray
    ) -> tuple[list[tuple[Cell, IntArray]], IntArray]:
        """The rows of ``fls_ids`` (M,) by the cell of ``band`` that holds each, as
        (cell, rows) in the cells' order, and the rows of ids that are not its FLSs.

        :meth:`cells_of` for a block of FLSs, in array operations: a packed
        process's FLSs make one block of offers a round, in a few dozen cells.
        """
        rows, found = self._rows_of(fls_ids)
        placed_rows = np.flatnonzero(found)
        if not len(placed_rows):
            return [], np.flatnonzero(~found)
        cells = self.placed[band][rows[placed_rows]]
        _, first, inverse = np.unique(_keys(cells), return_index=True, return_inverse=True)
        order = np.argsort(inverse, kind="stable")
        bounds = np.cumsum(np.bincount(inverse, minlength=len(first)))[:-1]
        groups = [
            ((band, *cell), placed_rows[at])
            for cell, at in zip(cells[first].tolist(), np.split(order, bounds), strict=True)
        ]
        return groups, np.flatnonzero(~found)

    def cells_of(self, band: str, fls_ids: IntArray) -> list[Cell | None]:
        """:meth:`cell_of` of each of ``fls_ids`` (M,), at once: a round's offers."""
        rows, found = self._rows_of(fls_ids)
        placed = self.placed[band][rows].tolist() if len(self.local) else [()] * len(rows)
        return [
            (band, *cell) if ok else None for cell, ok in zip(placed, found.tolist(), strict=True)
        ]


@dataclass
class Tuner:
    """A process's radio cells, worked out anew only when some FLS has changed cell.

    ``local``: the ids of the FLSs the process hosts. A heuristic's batch moves
    FLSs by less than r, two world revisions a batch, so most revisions change
    no FLS's cell; those that do are worked out in array operations over cell
    keys, since a display has thousands of FLSs to place.
    """

    cells: dict[str, Cells]
    local: IntArray
    _placed: dict[str, IntArray] | None = field(default=None, init=False, repr=False)

    def tune(self, ids: IntArray, points: FloatArray) -> Tuning | None:
        """The tuning for the FLSs ``ids`` (N,, sorted) at ``points`` (N, 3), cm; None when
        every FLS is in the cell it was in at the last tuning."""
        placed = {band: cells.of(points) for band, cells in self.cells.items()}
        if self._placed is not None and all(
            np.array_equal(placed[band], self._placed[band]) for band in placed
        ):
            return None
        self._placed = placed
        here = np.isin(ids, self.local)
        mine: set[Cell] = set()
        heard: set[Cell] = set()
        audible: dict[str, IntArray] = {}
        for band in self.cells:
            every = _keys(placed[band])
            own = np.unique(every[here])
            # The 27 cells around each of its FLSs' (AROUND's keys are offsets of keys).
            around = np.unique(own[:, None] + _OFFSET_KEYS[None, :])
            mine |= _cells_of_keys(band, own)
            audible[band] = ids[np.isin(every, around)]
            # Offers between this process's FLSs never cross DDS (broadcast): a cell
            # that holds none of another process's FLSs needs no subscription.
            heard |= _cells_of_keys(band, np.intersect1d(around, every[~here]))
        local = ids[here]
        return Tuning(
            frozenset(mine),
            frozenset(heard),
            audible,
            local,
            {b: c[here] for b, c in placed.items()},
        )
