"""What an FLS hears of its neighbours' cameras: the readings their measurements carry.

A source's least-squares fit (:func:`~swazure_ros.core.window_fit.window_fit`) needs
the readings of every FLS in its radio window. Each FLS publishes its own
(the ``measurements`` topic, latched); a process keeps the newest of each
FLS in one :class:`ReadingsBook`, and each of its FLSs takes its window's
rows from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.observe import LocalView
from ..core.sensor import DECAYING, SWEET
from ..core.window_fit import Heard


@dataclass(frozen=True)
class Readings:
    """One FLS's camera readings: whom it measured (K,), how (range class, vector, cm), how far."""

    owner: int
    other: IntArray  # (K,)
    range_class: NDArray[np.int8]  # (K,), SWEET or DECAYING
    distance: FloatArray  # (K,), tracking distance by radio, cm
    vector: FloatArray  # (K, 3), measured vector owner -> other, cm


def readings_of(view: LocalView) -> Readings:
    """What ``view``'s FLS measures: its neighbours in camera range, in sight, read."""
    camera = (view.range_class == SWEET) | (view.range_class == DECAYING)
    read = view.visible & camera & view.read
    return Readings(
        view.fls_id,
        view.other[read],
        view.range_class[read],
        view.distance[read],
        view.vector_at(read),
    )


class ReadingsBook:
    """The newest readings heard from each FLS."""

    def __init__(self) -> None:
        self._by_owner: dict[int, Readings] = {}

    def __len__(self) -> int:
        return len(self._by_owner)

    def put(self, readings: Readings) -> None:
        """Keep ``readings``, in place of their FLS's earlier ones."""
        self._by_owner[readings.owner] = readings

    def has(self, window: IntArray) -> bool:
        """True when every FLS of ``window`` (ids) has been heard."""
        return all(int(fls) in self._by_owner for fls in window.tolist())

    def heard(self, window: IntArray) -> Heard:
        """The readings heard between FLSs of ``window`` (ids)."""
        members = np.asarray(window, dtype=np.int64)
        held = [self._by_owner.get(int(fls)) for fls in members.tolist()]
        rows = [(one, np.isin(one.other, members)) for one in held if one is not None]

        def joined(name: str, empty: NDArray[Any]) -> NDArray[Any]:
            return np.concatenate([getattr(one, name)[keep] for one, keep in rows] + [empty])

        owner = [np.full(int(keep.sum()), one.owner, dtype=np.int64) for one, keep in rows]
        return Heard(
            np.concatenate([*owner, np.zeros(0, dtype=np.int64)]),
            joined("other", np.zeros(0, dtype=np.int64)),
            joined("range_class", np.zeros(0, dtype=np.int8)),
            joined("distance", np.zeros(0)),
            joined("vector", np.zeros((0, 3))),
        )
