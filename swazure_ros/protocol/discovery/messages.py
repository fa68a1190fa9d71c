"""What discovery's parties say: the coordinator's controls, an FLS's offers and reports.

Each is the data of one message (docs/protocol.md): :class:`Control` of a
DiscoveryControl, :class:`Offer` and :class:`Broadcast` of a PathOffer,
:class:`Report` of a PoseEstimates. :class:`RoundOffers` is what one process
heard in a round, grouped by sender, as the radio hands it to its FLSs.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...core import csr, jit
from ...core.arrays import FloatArray, IdArray, IntArray
from ...core.fit import PATH
from ...core.paths import FEWEST_HOPS
from ...core.swarm_fit import UNIT
from .estimate import Estimate

# Phases; the values equal swazure_interfaces/DiscoveryControl's PHASE_*.
SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE = 0, 1, 2


PHASES = (SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE)


PHASE_NAMES = ("S_vis", "S_all", "SD_vis")


#: After discovery's phases, a run of the swarm's fit solves it (protocol.swarm_fit).
FIT = 3


# The coordinator's commands; the values equal DiscoveryControl's COMMAND_*.
START, ROUND, END = 0, 1, 2

# Stages of the FIT phase; the values equal swazure_interfaces/DiscoveryControl's FIT_*.
LABELS, POSITIONS, WEIGH, RESIDUAL, SUMS, STEP, SHARE = range(7)
STAGE_NAMES = ("labels", "positions", "weigh", "residual", "sums", "step", "share")
#: The mode of a RESIDUAL that starts the covariance's solve, beside core.swarm_fit's
#: UNIT, HUBER and REJECTING weights.
SAMPLES = 3
#: How a solve ended, told in the round after it (FitStep.ended).
SETTLED, STALLED = 1, 2


@dataclass(frozen=True)
class FitStep:
    """What a control of the FIT phase tells the FLSs: the stage, the fit, how, the sums."""

    stage: int = LABELS
    layer: int = 0  # which of core.fit_measurements.fit_layers
    mode: int = UNIT  # RESIDUAL: the weights (UNIT, HUBER, REJECTING) or SAMPLES
    sums: tuple[float, ...] = ()  # STEP: the swarm's sums, (r, u) then (H u, u), per column
    ended: int = 0  # the round after a solve: SETTLED, or STALLED (each FLS takes its best)


@dataclass(frozen=True)
class FitOffer:
    """One FLS's say in a round of the FIT phase: to its neighbours, and to the coordinator."""

    label: int = -1  # LABELS: the smallest id of its sweet part heard of
    values: FloatArray = field(default_factory=lambda: np.zeros(0))  # the stage's vector, flat
    partials: FloatArray = field(default_factory=lambda: np.zeros(0))  # its shares (P,)
    moved: float = 0.0  # WEIGH: cm over the last solve
    same: tuple[bool, bool] = (True, True)  # WEIGH: Huber's, the rejecting weights unchanged
    changed: bool = False  # LABELS: its label changed
    # LABELS, its first round: its readings of the FLSs it measures, ids (R,) and cm (R, 3).
    readings: tuple[IntArray, FloatArray] | None = None


@dataclass
class Offer:
    """One FLS's labels of one round (L of them), as a PathOffer message carries them."""

    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    errors: FloatArray  # (L,), expected error summed over the hops (core.hop_errors.hop_error)
    vectors: FloatArray  # (L, 3), cm, summed from the source to the sender
    path_offsets: IntArray  # (L + 1,)
    path_ids: IdArray  # FLS ids, each path source first; uint32 as on the wire
    pending: bool = False
    finished: bool = False
    # A fitting run's labels also sum their hops less the known bias and the hops'
    # covariances (core.fit.path_estimates): a source's fallback beyond its window.
    unbiased: FloatArray | None = None  # (L, 3), cm
    covariances: FloatArray | None = None  # (L, 3, 3), cm^2
    # In its first offer of a phase, where a pair's two ends read it differently, the
    # sender's readings of its neighbours: each hop sender -> receiver is the sender's.
    reading_ids: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))  # (K,)
    reading_vectors: FloatArray = field(default_factory=lambda: np.zeros((0, 3)))  # (K, 3), cm
    # A round of the FIT phase: what the sender says to its neighbours and the coordinator.
    fit: FitOffer | None = None
    # Sources whose labels the sender holds beyond the pass's reach, unsent (not on the
    # wire: its process tells the coordinator, whose next pass reaches twice as far).
    beyond_ids: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    # The memory the sender's labels take, bytes (LabelTable.row_bytes; not on the wire:
    # its process tells the coordinator, which sizes the next run's block by it).
    label_bytes: int = 0

    def __len__(self) -> int:
        return len(self.source_ids)

    def path(self, label: int) -> tuple[int, ...]:
        """Path of label ``label``, FLS ids from its source to the sender."""
        start, stop = self.path_offsets[label], self.path_offsets[label + 1]
        return tuple(int(fls) for fls in self.path_ids[start:stop])


def _spanned(arrays: list[NDArray[Any]]) -> NDArray[Any] | None:
    """One view over ``arrays`` when they are consecutive slices of one array, in order;
    else None.

    A process's own offers are such slices (:func:`.heard.offers_of` reads every
    FLS's in one pass): joining them back is then a view, not a copy of a round's
    labels (3.6 s of torus:3720's 33 s discovery in one process, as copies).
    """
    # An empty slice adds nothing, and numpy may give it its array's start as its place.
    arrays = [array for array in arrays if array.size]
    if not arrays:
        return None
    first = arrays[0]
    base = first.base
    if not isinstance(base, np.ndarray) or not base.flags.c_contiguous:
        return None
    at = first.__array_interface__["data"][0]
    start = at
    for array in arrays:
        if (
            array.base is not base
            or array.dtype != first.dtype
            or array.shape[1:] != first.shape[1:]
            or not array.flags.c_contiguous
            or array.__array_interface__["data"][0] != at
        ):
            return None
        at += array.nbytes
    offset, end = start - base.__array_interface__["data"][0], at - start
    flat = base.reshape(-1).view(np.uint8)[offset : offset + end]
    return flat.view(first.dtype).reshape(-1, *first.shape[1:])


@dataclass(frozen=True)
class RoundOffers:
    """The offers one process heard in a round, L labels in all, grouped by sender.

    Built once per round and process (:meth:`of`); each local FLS then reads
    the labels of the senders it hears in one compiled pass (:func:`_relax`);
    :meth:`labels_of` lists them.
    """

    senders: IntArray  # (S,) sorted sender ids
    starts: IntArray  # (S + 1,) sender k's labels are starts[k]:starts[k + 1]
    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    errors: FloatArray  # (L,)
    vectors: FloatArray  # (L, 3), cm
    path_offsets: IntArray  # (L + 1,)
    path_ids: IdArray  # uint32 (Offer.path_ids)
    unbiased: FloatArray  # (L, 3), cm; NaN where an offer carried none
    covariances: FloatArray  # (L, 3, 3), cm^2; NaN where an offer carried none
    # Every reading the offers carried, sorted by the FLS read, then by the sender.
    read_ids: IntArray  # (R,), the FLS read
    read_by: IntArray  # (R,), the sender that read it
    read_vectors: FloatArray  # (R, 3), cm, read_by -> read_ids
    # The FIT phase's offers, one per sender of ``senders``: its label (-1: none) and vector.
    fit_labels: IntArray  # (S,)
    fit_offsets: IntArray  # (S + 1,)
    fit_values: FloatArray  # flat

    @classmethod
    def of(
        cls, heard: Sequence[tuple[int, Offer]], blocks: Sequence[FitBlock] = ()
    ) -> RoundOffers:
        """The offers ``heard``, as (sender, offer), and the rows of ``blocks``, in one table.

        A sender of a block has no offer in ``heard`` nor in another block.
        """
        table = cls._of(heard)
        blocks = [block for block in blocks if len(block)]
        return table._with_blocks(blocks) if blocks else table

    def _with_blocks(self, blocks: Sequence[FitBlock]) -> RoundOffers:
        """This table and the FIT offers of ``blocks`` (no label, no reading), by sender."""
        rows = sum(len(block) for block in blocks)
        senders = np.concatenate([self.senders, *(block.senders for block in blocks)])
        order = np.argsort(senders, kind="stable")
        sizes = np.concatenate(
            [np.diff(self.fit_offsets)]
            + [np.full(len(block), block.values.shape[1], dtype=np.int64) for block in blocks]
        )
        if not len(self.senders) and len(blocks) == 1:
            values = blocks[0].values.reshape(-1)  # one process's own: a view, in order
        else:
            flat = np.concatenate(
                [self.fit_values, *(block.values.reshape(-1) for block in blocks)]
            )
            values = flat[csr.ragged_indices(csr.offsets(sizes)[:-1][order], sizes[order])]
        labels = np.concatenate([np.diff(self.starts), np.zeros(rows, dtype=np.int64)])
        fit_labels = np.concatenate([self.fit_labels, np.full(rows, -1, dtype=np.int64)])
        return replace(
            self,
            senders=senders[order],
            starts=csr.offsets(labels[order]).astype(np.int64),
            fit_labels=fit_labels[order],
            fit_offsets=csr.offsets(sizes[order]).astype(np.int64),
            fit_values=values,
        )

    @classmethod
    def _of(cls, heard: Sequence[tuple[int, Offer]]) -> RoundOffers:
        heard = sorted(heard, key=lambda entry: entry[0])
        offers = [offer for _, offer in heard]
        counts = np.array([len(offer) for offer in offers], dtype=np.int64)
        senders = np.array([sender for sender, _ in heard], dtype=np.int64)
        unique, first = np.unique(senders, return_index=True)
        starts = csr.offsets(counts)

        # A round of the FIT phase carries no label: nothing to join, offer by offer.
        labelled = bool(counts.any())

        def joined(arrays: list[NDArray[Any]], empty: NDArray[Any]) -> NDArray[Any]:
            if not arrays or not labelled:
                return empty
            spanned = _spanned(arrays)
            return np.concatenate(arrays) if spanned is None else spanned

        # Each offer's path offsets start at 0: the steps within an offer are its paths'
        # lengths, one diff over all of them less the steps from one offer to the next.
        steps = np.diff(joined([offer.path_offsets for offer in offers], np.zeros(1, int)))
        path_lengths = np.delete(steps, np.cumsum(counts + 1)[:-1] - 1) if labelled else steps

        def carried(name: str, shape: tuple[int, ...]) -> FloatArray:
            """A fitting run's sums, NaN where an offer had none (read-only if none had)."""
            values = [getattr(offer, name) for offer in offers]
            if not labelled or all(value is None for value in values):
                return np.broadcast_to(np.nan, (int(counts.sum()), *shape))
            return joined(
                [
                    np.full((len(offer), *shape), np.nan) if value is None else value
                    for offer, value in zip(offers, values, strict=True)
                ],
                np.zeros((0, *shape)),
            )

        return cls(
            senders=unique,
            starts=np.append(starts[first], starts[-1]).astype(np.int64),
            source_ids=joined([offer.source_ids for offer in offers], np.zeros(0, np.int64)),
            hops=joined([offer.hops for offer in offers], np.zeros(0, np.int64)),
            lengths=joined([offer.lengths for offer in offers], np.zeros(0)),
            errors=joined([offer.errors for offer in offers], np.zeros(0)),
            vectors=joined([offer.vectors for offer in offers], np.zeros((0, 3))),
            path_offsets=csr.offsets(path_lengths),
            path_ids=joined([offer.path_ids for offer in offers], np.zeros(0, np.uint32)),
            unbiased=carried("unbiased", (3,)),
            covariances=carried("covariances", (3, 3)),
            **_readings_table(heard),
            **_fit_table([offers[index] for index in first.tolist()]),
        )

    def fit_of(self, wanted: IntArray) -> tuple[IntArray, IntArray, FloatArray]:
        """The FIT phase's offers of ``wanted`` (W,) sorted ids: labels (W,), -1 where none;
        offsets (W + 1,) into the vectors, flat."""
        rows = sender_rows(np.asarray(wanted, dtype=np.int64), self.senders)
        found = rows >= 0
        labels = np.full(len(rows), -1, dtype=np.int64)
        labels[found] = self.fit_labels[rows[found]]
        low = np.zeros(len(rows), dtype=np.int64)
        high = np.zeros(len(rows), dtype=np.int64)
        low[found] = self.fit_offsets[rows[found]]
        high[found] = self.fit_offsets[rows[found] + 1]
        values = self.fit_values[csr.ragged_indices(low, high - low)]
        return labels, csr.offsets(high - low), values

    def readings_of(self, fls: int) -> tuple[IntArray, FloatArray]:
        """The senders that read FLS ``fls`` (sorted) and their readings of it (cm)."""
        low, high = np.searchsorted(self.read_ids, [fls, fls + 1])
        return self.read_by[low:high], self.read_vectors[low:high]

    def __len__(self) -> int:
        return len(self.source_ids)

    def _rows(self, senders: IntArray) -> IntArray:
        """Rows into :attr:`senders` of those of ``senders`` that offered."""
        rows = sender_rows(np.asarray(senders, dtype=np.int64), self.senders)
        return rows[rows >= 0]

    def senders_of(self, labels: IntArray) -> IntArray:
        """(M,) the sender of each of ``labels`` (M,): looked up, not held (L ids a round)."""
        return self.senders[np.searchsorted(self.starts, labels, side="right") - 1]

    def labels_of(self, senders: IntArray) -> IntArray:
        """(M,) the labels offered by ``senders`` (sorted ids), sender by sender."""
        rows = self._rows(senders)
        low, high = self.starts[rows], self.starts[rows + 1]
        return csr.ragged_indices(low, high - low)

    def path(self, label: int) -> tuple[int, ...]:
        """Path of label ``label``, FLS ids from its source to the sender."""
        return self.paths(np.array([label], dtype=np.int64))[0]

    def paths(self, labels: IntArray) -> list[tuple[int, ...]]:
        """Paths of ``labels`` (M,), each FLS ids from its source to the sender."""
        start, stop = self.path_offsets[labels], self.path_offsets[labels + 1]
        ids = self.path_ids[csr.ragged_indices(start, stop - start)].tolist()
        bounds = csr.offsets(stop - start).tolist()
        return [tuple(ids[low:high]) for low, high in itertools.pairwise(bounds)]


def _fit_table(offers: Sequence[Offer]) -> dict[str, NDArray[Any]]:
    """The FIT phase's part of ``offers`` (one per sender, in sender order)."""
    fits = [offer.fit for offer in offers]
    labels = np.array([-1 if fit is None else fit.label for fit in fits], dtype=np.int64)
    values = [np.zeros(0) if fit is None else fit.values for fit in fits]
    counts = np.array([len(value) for value in values], dtype=np.int64)
    flat = np.concatenate(values) if values else np.zeros(0)
    return {"fit_labels": labels, "fit_offsets": csr.offsets(counts), "fit_values": flat}


def _readings_table(heard: Sequence[tuple[int, Offer]]) -> dict[str, NDArray[Any]]:
    """The readings of the offers ``heard`` as RoundOffers holds them."""
    counts = [len(offer.reading_ids) for _, offer in heard]
    if not sum(counts):
        empty = np.zeros(0, dtype=np.int64)
        return {"read_ids": empty, "read_by": empty, "read_vectors": np.zeros((0, 3))}
    read_ids = np.concatenate([offer.reading_ids for _, offer in heard]).astype(np.int64)
    read_by = np.repeat([sender for sender, _ in heard], counts).astype(np.int64)
    vectors = np.concatenate([offer.reading_vectors for _, offer in heard])
    order = np.lexsort((read_by, read_ids))
    return {"read_ids": read_ids[order], "read_by": read_by[order], "read_vectors": vectors[order]}


@dataclass(frozen=True)
class Control:
    """One tick of the coordinator's round clock (a DiscoveryControl message)."""

    run_id: int
    command: int  # START, ROUND or END
    phase: int = SWEET_VISIBLE
    policy: str = FEWEST_HOPS
    round: int = 0
    expected: int = 0  # FLSs that take part: each sends one offer per round
    source_ids: tuple[int, ...] = ()  # START: the searching sources; empty: every FLS
    target_ids: tuple[int, ...] = ()  # START: the one target of each listed source
    finished_ids: tuple[int, ...] = ()  # ROUND: sources whose search ended since the last round
    departed_ids: tuple[int, ...] = ()  # FLSs declared gone: nobody relays through them
    estimator: str = PATH  # START: one of core.fit.SWARM_ESTIMATORS
    fit: FitStep = field(default_factory=lambda: FitStep())  # the FIT phase's ROUND
    # START: the phase's pass; pass k's searches reach 2**k times as far (buckets.reach_rounds).
    reach_pass: int = 0
    # START of a pass after the first: the sources whose search in the pass before ran out
    # of FLSs to label (it searched, nothing beyond its reach, not closed once finished).
    exhausted_ids: tuple[int, ...] = ()

    @cached_property
    def sources(self) -> IntArray:
        """``source_ids``, sorted, each once: one array for every FLS of a process that
        searches in the run (each keeps its labels by it, :class:`.labels.LabelTable`)."""
        return np.unique(np.asarray(self.source_ids, dtype=np.int64))

    @cached_property
    def finished(self) -> IntArray:
        """``finished_ids`` as one array, made once for all the FLSs of a process that close
        those searches (one each a ROUND, thousands in a packed process)."""
        return np.asarray(self.finished_ids, dtype=np.int64)

    @cached_property
    def exhausted(self) -> IntArray:
        """``exhausted_ids``, sorted: made once for all the FLSs of a process that read it
        (as many ids as sources, and a packed process steps thousands of FLSs)."""
        return np.unique(np.asarray(self.exhausted_ids, dtype=np.int64))


@dataclass(frozen=True)
class Broadcast:
    """An FLS's offer of one round, for the radio (a PathOffer message)."""

    run_id: int
    phase: int
    round: int
    sender: int
    offer: Offer


@dataclass(frozen=True)
class FitBlock:
    """The offers of one FIT round that S FLSs of one process made together, a row each.

    What S :class:`Broadcast` of :func:`fit_offer` would carry, in columns: a
    SUMS or STEP round's offer has no label, no reading and no move, only a
    vector (``values``) or the sender's shares of the swarm's sums
    (``partials``). A process's radio keeps and tallies the block whole, and
    puts a row on the wire as a PathOffer of its own (:meth:`broadcast`) only
    where someone else reads the sender's cell: a Python object per FLS and
    round was most of what a packed process spent in the fit's hundreds of
    rounds.
    """

    run_id: int
    round: int
    senders: IntArray  # (S,) FLS ids, ascending
    values: FloatArray  # (S, V): each sender's vector, flat (V may be 0)
    partials: FloatArray  # (S, P): each sender's shares of the swarm's sums (P may be 0)
    phase: int = FIT

    def __len__(self) -> int:
        return len(self.senders)

    def rows(self, which: NDArray[np.bool_]) -> FitBlock:
        """The block of the rows ``which`` (S,) picks."""
        return replace(
            self,
            senders=self.senders[which],
            values=self.values[which],
            partials=self.partials[which],
        )

    def said(self, row: int) -> FitOffer:
        """The FitOffer of row ``row``, as its sender stepping alone makes it."""
        return FitOffer(values=self.values[row], partials=self.partials[row])

    def broadcast(self, row: int) -> Broadcast:
        """Row ``row`` as its sender's own Broadcast (a PathOffer on the wire)."""
        sender = int(self.senders[row])
        return Broadcast(self.run_id, self.phase, self.round, sender, fit_offer(self.said(row)))

    def broadcasts(self) -> list[Broadcast]:
        """Every row as its sender's own Broadcast."""
        return [self.broadcast(row) for row in range(len(self))]


def _read_only(array: NDArray[Any]) -> NDArray[Any]:
    array.flags.writeable = False
    return array


# A FIT round's offer carries no label: every one shares these empty fields (read-only),
# rather than making seven arrays per FLS and round.
_NO_IDS = _read_only(np.zeros(0, dtype=np.int64))
_NO_VALUES = _read_only(np.zeros(0))
_NO_VECTORS = _read_only(np.zeros((0, 3)))
_NO_PATHS = _read_only(np.zeros(1, dtype=np.int64))


def fit_offer(said: FitOffer) -> Offer:
    """The offer of a round of the FIT phase: no label; its readings in its first."""
    ids, vectors = said.readings or (_NO_IDS, _NO_VECTORS)
    return Offer(
        _NO_IDS,
        _NO_IDS,
        _NO_VALUES,
        _NO_VALUES,
        _NO_VECTORS,
        _NO_PATHS,
        _NO_IDS,
        pending=said.changed,
        reading_ids=ids,
        reading_vectors=vectors,
        fit=said,
        beyond_ids=_NO_IDS,
    )


@dataclass(frozen=True)
class Report:
    """A source's estimates at the end of a run (a PoseEstimates message)."""

    run_id: int
    source: int
    estimates: Sequence[Estimate]  # an Estimates table where the protocol made them


@jit.kernel(cache=True, nogil=True)
def sender_rows(wanted: IntArray, senders: IntArray) -> IntArray:
    """(W,) the row of each id of ``wanted`` in ``senders``, -1 where absent; both sorted.

    By binary search: an FLS wants its few neighbours among a round's senders,
    which are the whole swarm in a packed process.
    """
    rows = np.full(len(wanted), -1, dtype=np.int64)
    found = np.searchsorted(senders, wanted)
    for k in range(len(wanted)):
        row = found[k]
        if row < len(senders) and senders[row] == wanted[k]:
            rows[k] = row
    return rows
