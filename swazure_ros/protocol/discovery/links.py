"""The hops FLSs relay from in a phase: what a :class:`~.labels.LabelTable`'s rows relax
labels through.

Each FLS relays from its neighbours that the phase allows, sorted by id. A
table's rows hold theirs side by side (CSR: ``starts``), made from each row's
:class:`RowHops` the first time the table relaxes a label, every row's at once
and written in place: a relay that hears no label in a phase never holds its
hops (in a display's SD_vis phase, tens of millions per process).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np

from ...core import csr
from ...core.arrays import FloatArray, IntArray
from ...core.hop_errors import hop_covariance, unbiased_vectors
from ...core.sensor import Sensor


class Links(NamedTuple):
    """The hops FLSs relay from, each FLS's sorted by sender id: one kernel argument."""

    ids: IntArray  # (K,), the senders
    weights: FloatArray  # (K,), tracking distance of each hop, cm
    errors: FloatArray  # (K,), expected error of each hop
    vectors: FloatArray  # (K, 3), cm, each hop sender -> FLS as its labels sum it; NaN unread


class RowHops(Protocol):
    """How one FLS's :class:`Links` are made, when its table first needs them."""

    def count(self) -> int:
        """How many hops the FLS relays from."""
        ...

    def fill(self, links: Links, start: int) -> None:
        """Write its hops into ``links`` from ``start`` on (``count()`` of them)."""
        ...


def made_links(hops: Sequence[RowHops]) -> tuple[IntArray, Links]:
    """(starts (F + 1,), links) of the FLSs ``hops``, each written in place once."""
    starts = csr.offsets(np.array([one.count() for one in hops], dtype=np.int64))
    size = int(starts[-1])
    links = Links(
        np.empty(size, dtype=np.int64),
        np.empty(size, dtype=np.float64),
        np.empty(size, dtype=np.float64),
        np.empty((size, 3), dtype=np.float64),
    )
    for one, start in zip(hops, starts[:-1].tolist(), strict=True):
        one.fill(links, start)
    return starts, links


class RowsLinks:
    """F rows' links: given (``starts`` (F + 1,) and ``links``), or made from ``row_hops``
    (F,) when first asked for."""

    def __init__(
        self,
        starts: IntArray | None,
        links: Links | None,
        row_hops: Sequence[RowHops] | None,
    ) -> None:
        if (links is None) == (row_hops is None) or (links is None) != (starts is None):
            raise ValueError("give a table link_starts and links, or row_hops to make them")
        self._starts, self._links, self._row_hops = starts, links, row_hops

    @property
    def made(self) -> bool:
        """True once the links are held."""
        return self._links is not None

    @property
    def starts(self) -> IntArray:
        """(F + 1,) where each row's links start in :attr:`links` (made if need be)."""
        return self._made()[0]

    @property
    def links(self) -> Links:
        """The rows' links, row f's at ``starts[f]:starts[f + 1]`` (made if need be)."""
        return self._made()[1]

    def row(self, row: int) -> Links:
        """Row ``row``'s links (made if need be)."""
        starts, links = self._made()
        mine = slice(starts[row], starts[row + 1])
        return Links(links.ids[mine], links.weights[mine], links.errors[mine], links.vectors[mine])

    def hops(self, row: int) -> RowHops:
        """How row ``row`` makes its links; ValueError once they are made."""
        if self._row_hops is None:
            raise ValueError("the links are made")
        return self._row_hops[row]

    def _made(self) -> tuple[IntArray, Links]:
        if self._starts is None or self._links is None:
            assert self._row_hops is not None
            self._starts, self._links = made_links(self._row_hops)
            self._row_hops = None
        return self._starts, self._links


def joined_links(rows: Sequence[Links]) -> tuple[IntArray, Links]:
    """(starts, links) of ``rows`` (each one FLS's links), one after another."""
    starts = csr.offsets(np.array([len(row.ids) for row in rows], dtype=np.int64))
    return starts, Links(*(np.concatenate(field) for field in zip(*rows, strict=True)))


def hop_fit(
    sensor: Sensor, radius: float, hop: FloatArray, tracking: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Hops (K, 3), cm, of tracking distance ``tracking`` (K,) less their known bias, and
    their covariances (K, 3, 3), cm^2; NaN without a reading. Labels sum both."""
    read = np.isfinite(hop).all(axis=1)
    unbiased = np.full_like(hop, np.nan)
    covariance = np.full((len(hop), 3, 3), np.nan)
    if read.any():
        unbiased[read] = unbiased_vectors(sensor, hop[read], tracking[read])
        directions = hop[read] / np.linalg.norm(hop[read], axis=1, keepdims=True)
        covariance[read] = hop_covariance(sensor, tracking[read], directions, radius)
    return unbiased, covariance
