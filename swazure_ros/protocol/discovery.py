"""Distributed path discovery: one FLS's part of the protocol of docs/protocol.md.

Every FLS runs a :class:`PathSearch` per phase of a discovery run. It holds
the FLS's best path label for each source: the path from the source to this
FLS, its hop count and length, and the measured hop vectors summed from the
source. In round k of a phase an FLS broadcasts the labels whose bucket is k
(:func:`bucket_width`); its neighbours relax them through their own hop.

Buckets make every broadcast label final. Every hop adds one hop, at least
``sweet_min`` of length and at least the sensor's smallest hop error (the
least-error policy's cost), so a label can only be improved by a label of a
lower bucket, which was broadcast in an earlier round. Each FLS
therefore broadcasts each source's label once, and keeps, among equal costs,
the label whose sender has the smallest FLS id: the predecessor rule of
:mod:`..core.paths`, so the distributed search picks the core engine's paths.

:class:`Participant` is one FLS's state machine over whole runs: the
coordinator's :class:`Control` messages and the neighbours' offers go in,
broadcasts and reports come out. The FLS nodes and the in-memory loop
(:mod:`.loops`) both drive it. :func:`estimate` turns one target's phase
results into the pair's status, reason and path, as section 5 of the spec
orders the phases.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core import csr, jit
from ..core.evaluate import (
    ABORTED,
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_COORDINATOR_LOST,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
    Evaluation,
    Neighbourhood,
    pair_results,
    summarise,
)
from ..core.fit import LOCAL_LEAST_SQUARES, PATH, Heard, consistency, window_fit
from ..core.neighbours import ordered_blind_pairs
from ..core.observe import LocalView
from ..core.paths import FEWEST_HOPS, LEAST_ERROR, SHORTEST_LENGTH, check_policy, paths_from_rows
from ..core.sensor import (
    BLIND,
    DECAYING,
    SWEET,
    Sensor,
    expected_error,
    hop_covariance,
    hop_error,
    smallest_hop_error,
    unbiased_vectors,
)
from .readings import ReadingsBook

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Phases; the values equal swazure_interfaces/DiscoveryControl's PHASE_*.
SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE = 0, 1, 2
PHASES = (SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE)
PHASE_NAMES = ("S_vis", "S_all", "SD_vis")
# The coordinator's commands; the values equal DiscoveryControl's COMMAND_*.
START, ROUND, END = 0, 1, 2

#: Rounds that one sweet hop may cost in a least-error run, at most: the calibrated
#: sensors' cost 24 and 88; a sensor whose error crosses zero in its range, tens of thousands.
MAX_ROUNDS_PER_HOP = 1000

#: Bucket widths sit this fraction below the shortest hop, so that rounding in
#: a sum of lengths never puts a label in the bucket of the label it extends.
_BUCKET_MARGIN = 1e-9

#: Discovery runs an FLS takes part in at once, at most: its coordinator runs one at a
#: time, and a run id that a peer made up must not hold memory for ever.
RUNS_KEPT = 4

#: How many rounds' offers a PathSearch keeps before it drops those no label needs.
_HEARD_KEPT = 8


#: The order of a label's costs in each policy: (primary, secondary), as _relax reads them.
_HOPS_FIRST, _LENGTH_FIRST, _ERROR_FIRST = 0, 1, 2
_COST_ORDER = {FEWEST_HOPS: _HOPS_FIRST, SHORTEST_LENGTH: _LENGTH_FIRST, LEAST_ERROR: _ERROR_FIRST}


def bucket_width(sensor: Sensor, radius: float, policy: str) -> float:
    """Cost per round: the smallest cost a hop can add under ``policy``, a little lowered.

    One hop for fewest-hops; just under ``sweet_min`` cm for shortest-length;
    :func:`~..core.sensor.smallest_hop_error` for least-error.
    """
    if check_policy(policy) == FEWEST_HOPS:
        return 1.0
    if policy == LEAST_ERROR:
        smallest = smallest_hop_error(sensor, radius)
        if not smallest > 0:
            raise ValueError(
                f"least-error needs a sensor whose every hop errs; {sensor.name} has hops "
                "without error (an accurate sensor has no least-error path)"
            )
        # A sweet hop's cost in buckets is what one hop costs in rounds: where the
        # error nearly vanishes inside the range, a run would take rounds without end.
        sweet = np.linspace(sensor.sweet_min, sensor.sweet_max, 1001)
        rounds = float(hop_error(sensor, sweet, radius).max() / smallest)
        if rounds > MAX_ROUNDS_PER_HOP:
            raise ValueError(
                f"least-error over {sensor.name or 'this sensor'} would take about "
                f"{rounds:,.0f} rounds a hop (its hop error falls to {smallest:.3g} inside the "
                f"camera's range; at most {MAX_ROUNDS_PER_HOP:,} are allowed): use "
                "shortest-length or fewest-hops"
            )
        return smallest
    if not sensor.sweet_min > 0:
        raise ValueError(f"sweet_min must be positive for shortest-length, got {sensor.sweet_min}")
    return sensor.sweet_min * (1.0 - _BUCKET_MARGIN)


def hop_mask(view: LocalView, phase: int) -> NDArray[np.bool_]:
    """(K,) the neighbours of ``view`` that its FLS relays from in ``phase``."""
    sweet = view.range_class == SWEET
    if phase == SWEET_VISIBLE:
        return np.asarray(sweet & view.visible)
    if phase == SWEET_ALL:
        return np.asarray(sweet)
    if phase == ANY_VISIBLE:
        return np.asarray((sweet | (view.range_class == DECAYING)) & view.visible)
    raise ValueError(f"unknown discovery phase {phase}")


@dataclass
class Offer:
    """One FLS's labels of one round (L of them), as a PathOffer message carries them."""

    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    errors: FloatArray  # (L,), expected error summed over the hops (core.sensor.hop_error)
    vectors: FloatArray  # (L, 3), cm, summed from the source to the sender
    path_offsets: IntArray  # (L + 1,)
    path_ids: IntArray
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

    def __len__(self) -> int:
        return len(self.source_ids)

    def path(self, label: int) -> tuple[int, ...]:
        """Path of label ``label``, FLS ids from its source to the sender."""
        start, stop = self.path_offsets[label], self.path_offsets[label + 1]
        return tuple(int(fls) for fls in self.path_ids[start:stop])


def reads_both_ends(sensor: Sensor) -> bool:
    """True when the two FLSs of a pair read its vector differently (noise, a camera).

    The published model's reading of j from i is the reverse of i's from j,
    to the bit: a receiver may take its own reading of the sender, reversed.
    """
    return sensor.noise is not None or sensor.camera is not None


@dataclass(frozen=True)
class Found:
    """A path from a source to one FLS: ids, hops, length (cm) and summed vector (3,), cm."""

    path: tuple[int, ...]
    length: float
    vector: FloatArray
    error: float = float("nan")  # the hops' expected errors summed (core.sensor.hop_error)
    unbiased: FloatArray | None = None  # (3,), cm: the hops less their known bias, summed
    covariance: FloatArray | None = None  # (3, 3), cm^2: the hops' covariances summed

    @property
    def hops(self) -> int:
        """Number of hops."""
        return len(self.path) - 1


@dataclass(frozen=True)
class RoundOffers:
    """The offers one process heard in a round, L labels in all, grouped by sender.

    Built once per round and process (:meth:`of`); each local FLS then reads
    the labels of the senders it hears in one compiled pass (:func:`_relax`);
    :meth:`labels_of` lists them.
    """

    senders: IntArray  # (S,) sorted sender ids
    starts: IntArray  # (S + 1,) sender k's labels are starts[k]:starts[k + 1]
    sender_ids: IntArray  # (L,)
    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    errors: FloatArray  # (L,)
    vectors: FloatArray  # (L, 3), cm
    path_offsets: IntArray  # (L + 1,)
    path_ids: IntArray
    unbiased: FloatArray  # (L, 3), cm; NaN where an offer carried none
    covariances: FloatArray  # (L, 3, 3), cm^2; NaN where an offer carried none
    # Every reading the offers carried, sorted by the FLS read, then by the sender.
    read_ids: IntArray  # (R,), the FLS read
    read_by: IntArray  # (R,), the sender that read it
    read_vectors: FloatArray  # (R, 3), cm, read_by -> read_ids

    @classmethod
    def of(cls, heard: Sequence[tuple[int, Offer]]) -> RoundOffers:
        """The offers ``heard``, as (sender, offer), in one table."""
        heard = sorted(heard, key=lambda entry: entry[0])
        offers = [offer for _, offer in heard]
        counts = np.array([len(offer) for offer in offers], dtype=np.int64)
        senders = np.array([sender for sender, _ in heard], dtype=np.int64)
        unique, first = np.unique(senders, return_index=True)
        starts = csr.offsets(counts)

        def joined(arrays: list[NDArray[Any]], empty: NDArray[Any]) -> NDArray[Any]:
            return np.concatenate(arrays) if arrays else empty

        path_lengths = joined([np.diff(offer.path_offsets) for offer in offers], np.zeros(0, int))

        def carried(offer: Offer, values: FloatArray | None, shape: tuple[int, ...]) -> FloatArray:
            return values if values is not None else np.full((len(offer), *shape), np.nan)

        return cls(
            senders=unique,
            starts=np.append(starts[first], starts[-1]).astype(np.int64),
            sender_ids=np.repeat(senders, counts),
            source_ids=joined([offer.source_ids for offer in offers], np.zeros(0, np.int64)),
            hops=joined([offer.hops for offer in offers], np.zeros(0, np.int64)),
            lengths=joined([offer.lengths for offer in offers], np.zeros(0)),
            errors=joined([offer.errors for offer in offers], np.zeros(0)),
            vectors=joined([offer.vectors for offer in offers], np.zeros((0, 3))),
            path_offsets=csr.offsets(path_lengths),
            path_ids=joined([offer.path_ids for offer in offers], np.zeros(0, np.int64)),
            unbiased=joined(
                [carried(offer, offer.unbiased, (3,)) for offer in offers], np.zeros((0, 3))
            ),
            covariances=joined(
                [carried(offer, offer.covariances, (3, 3)) for offer in offers],
                np.zeros((0, 3, 3)),
            ),
            **_readings_table(heard),
        )

    def readings_of(self, fls: int) -> tuple[IntArray, FloatArray]:
        """The senders that read FLS ``fls`` (sorted) and their readings of it (cm)."""
        low, high = np.searchsorted(self.read_ids, [fls, fls + 1])
        return self.read_by[low:high], self.read_vectors[low:high]

    def __len__(self) -> int:
        return len(self.source_ids)

    def _rows(self, senders: IntArray) -> IntArray:
        """Rows into :attr:`senders` of those of ``senders`` that offered."""
        rows = _sender_rows(np.asarray(senders, dtype=np.int64), self.senders)
        return rows[rows >= 0]

    def labels_of(self, senders: IntArray) -> IntArray:
        """(M,) the labels offered by ``senders`` (sorted ids), sender by sender."""
        rows = self._rows(senders)
        low, high = self.starts[rows], self.starts[rows + 1]
        return csr.ragged_indices(low, high - low)

    def path(self, label: int) -> tuple[int, ...]:
        """Path of label ``label``, FLS ids from its source to the sender."""
        start, stop = self.path_offsets[label], self.path_offsets[label + 1]
        return tuple(self.path_ids[start:stop].tolist())


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


@jit.kernel(cache=True, nogil=True)
def _sender_rows(wanted: IntArray, senders: IntArray) -> IntArray:
    """(W,) the row of each id of ``wanted`` in ``senders``, -1 where absent; both sorted."""
    rows = np.full(len(wanted), -1, dtype=np.int64)
    row = 0
    for k in range(len(wanted)):
        while row < len(senders) and senders[row] < wanted[k]:
            row += 1
        if row < len(senders) and senders[row] == wanted[k]:
            rows[k] = row
    return rows


@jit.kernel(cache=True, nogil=True)
def _labels_for(
    source: int,
    senders_wanted: IntArray,
    senders: IntArray,
    starts: IntArray,
    source_ids: IntArray,
) -> IntArray:
    """The labels of ``source`` offered by ``senders_wanted`` (sorted ids), sender by sender.

    ``senders``, ``starts`` and ``source_ids`` are a :class:`RoundOffers`'s;
    a sender offers each source's label once in a phase (it is final when sent).
    """
    found = np.empty(len(senders_wanted), dtype=np.int64)
    count = 0
    for row in _sender_rows(senders_wanted, senders):
        if row < 0:
            continue
        for label in range(starts[row], starts[row + 1]):
            if source_ids[label] == source:
                found[count] = label
                count += 1
                break
    return found[:count]


@jit.kernel(cache=True, nogil=True)
def _relax(
    me: int,
    link_ids: IntArray,
    link_weights: FloatArray,
    link_errors: FloatArray,
    order: int,
    senders: IntArray,
    starts: IntArray,
    source_ids: IntArray,
    label_hops: IntArray,
    label_lengths: FloatArray,
    label_errors: FloatArray,
    sent: NDArray[np.bool_],
    hops: FloatArray,
    length: FloatArray,
    error: FloatArray,
    pred: IntArray,
    won_label: IntArray,
    won_link: IntArray,
) -> IntArray:
    """Relax the labels (hops, length, error, pred: (id_space,)) through the hops of ``link_ids``.

    Each candidate (a heard label plus the hop from its sender) replaces the
    label of its source when it is better under the total order (primary
    cost, secondary cost, sender id), so the outcome does not depend on the
    order of hearing. The winning label and hop are left in ``won_label``
    and ``won_link`` (given all -1); returns the changed sources.
    """
    changed = np.empty(len(hops), dtype=np.int64)
    count = 0
    rows = _sender_rows(link_ids, senders)
    for link in range(len(link_ids)):
        row = rows[link]
        if row < 0:
            continue
        sender = link_ids[link]
        weight, link_error = link_weights[link], link_errors[link]
        for label in range(starts[row], starts[row + 1]):
            source = source_ids[label]
            if sent[source] or source == me:
                continue
            # Sums in path order, as the engine sums them: cost so far plus this hop.
            new_hops = label_hops[label] + 1.0
            new_length = label_lengths[label] + weight
            new_error = label_errors[label] + link_error
            if order == _HOPS_FIRST:
                new1, new2, old1, old2 = new_hops, new_length, hops[source], length[source]
            elif order == _LENGTH_FIRST:
                new1, new2, old1, old2 = new_length, new_hops, length[source], hops[source]
            else:
                new1, new2, old1, old2 = new_error, new_hops, error[source], hops[source]
            if new1 < old1 or (
                new1 == old1 and (new2 < old2 or (new2 == old2 and sender < pred[source]))
            ):
                if won_label[source] < 0:
                    changed[count] = source
                    count += 1
                hops[source], length[source], error[source] = new_hops, new_length, new_error
                pred[source] = sender
                won_label[source], won_link[source] = label, link
    return changed[:count]


class PathSearch:
    """One FLS's labels in one phase of a discovery run.

    ``id_space`` bounds the FLS ids (ids are below it). ``targets`` makes this
    FLS a source that searches for them; ``departed`` FLSs are not relayed from.
    ``hop_errors`` (K,) is the expected error of the hop to each neighbour of
    ``view`` (core.sensor.hop_error), which labels sum as they sum lengths.
    ``fit`` (the sensor and the FLSs' radius, cm), given in a fitting run,
    makes labels also sum each hop less its known bias, and its covariance.
    With ``both_ends``, a hop sender -> this FLS is the sender's own reading,
    which the sender's first offer of the phase carries
    (:func:`reads_both_ends`); else this FLS's reading of the sender, reversed.
    """

    def __init__(
        self,
        view: LocalView,
        phase: int,
        policy: str,
        width: float,
        id_space: int,
        targets: IntArray | None = None,
        departed: frozenset[int] = frozenset(),
        hop_errors: FloatArray | None = None,
        fit: tuple[Sensor, float] | None = None,
        both_ends: bool = False,
    ) -> None:
        self.fls_id = view.fls_id
        self.order = _COST_ORDER[check_policy(policy)]
        self.width = width
        hop = hop_mask(view, phase) & ~np.isin(view.other, list(departed))
        # The neighbours relayed from, sorted by id (a view lists them so), with the
        # hop sender -> self, which this FLS's camera measures the other way round.
        order = np.argsort(view.other[hop], kind="stable")
        self.link_ids = np.asarray(view.other[hop][order], dtype=np.int64)
        self.link_weights = np.asarray(view.distance[hop][order], dtype=np.float64)
        errors = np.zeros(len(view.other)) if hop_errors is None else hop_errors
        self.link_errors = np.asarray(errors[hop][order], dtype=np.float64)
        own = np.asarray(view.vector[hop][order], dtype=np.float64)
        self.link_vectors = np.full_like(own, np.nan) if both_ends else -own
        # This FLS's readings of the neighbours it relays to, sent once when both ends read.
        read = np.isfinite(own).all(axis=1)
        self._readings: tuple[IntArray, FloatArray] | None = (
            (self.link_ids[read], own[read]) if both_ends else None
        )
        self.fit = fit
        self.fits = fit is not None
        if fit is not None:
            self.unbiased = np.full((id_space, 3), np.nan)
            self.covariance = np.full((id_space, 3, 3), np.nan)
        self.hops = np.full(id_space, np.inf)
        self.length = np.full(id_space, np.inf)
        self.error = np.full(id_space, np.inf)
        self.pred = np.full(id_space, np.iinfo(np.int64).max, dtype=np.int64)
        self.vector = np.full((id_space, 3), np.nan)
        self.sent = np.zeros(id_space, dtype=bool)
        self.closed = np.zeros(id_space, dtype=bool)  # sources whose search has ended
        # A label's path is its sender's (label via_label of the offers heard as
        # via_offers) plus this FLS; it is copied out only when the label is sent,
        # since most labels are bettered before they are.
        self.via_offers = np.full(id_space, -1, dtype=np.int64)  # -1: this FLS is the source
        self.via_label = np.full(id_space, -1, dtype=np.int64)
        self._heard: dict[int, RoundOffers] = {}
        self._heard_count = 0
        self.targets = frozenset(int(t) for t in targets) if targets is not None else frozenset()
        self._wanted = np.array(sorted(self.targets), dtype=np.int64)
        self._found = np.zeros(id_space, dtype=bool)
        self.results: dict[int, Found] = {}
        if targets is not None:
            me = self.fls_id
            self.hops[me], self.length[me], self.error[me], self.pred[me] = 0.0, 0.0, 0.0, me
            self.vector[me] = 0.0
            if self.fits:
                self.unbiased[me], self.covariance[me] = 0.0, 0.0

    @property
    def finished(self) -> bool:
        """True when this FLS, as a source, has a result for every target."""
        return bool(self.targets) and len(self.results) == len(self.targets)

    def _buckets(self, sources: IntArray) -> FloatArray:
        primary = (self.hops, self.length, self.error)[self.order][sources]
        return np.asarray(np.floor(primary / self.width))

    def close(self, sources: IntArray) -> None:
        """Stop relaying the labels of ``sources`` (their searches ended)."""
        self.closed[np.asarray(sources, dtype=np.int64)] = True

    def offer(self, round_: int) -> Offer:
        """The labels due in round ``round_`` (each is final); they count as sent."""
        labelled = np.flatnonzero(np.isfinite(self.hops) & ~self.sent & ~self.closed)
        due = labelled[self._buckets(labelled) <= round_]
        self.sent[due] = True
        path_offsets, path_ids = self._paths_of(due)
        return Offer(
            source_ids=due.astype(np.int64),
            hops=self.hops[due].astype(np.int64),
            lengths=self.length[due],
            errors=self.error[due],
            vectors=self.vector[due],
            path_offsets=path_offsets,
            path_ids=path_ids,
            pending=len(due) < len(labelled),
            finished=self.finished,
            unbiased=self.unbiased[due] if self.fits else None,
            covariances=self.covariance[due] if self.fits else None,
            **self._first_readings(),
        )

    def _first_readings(self) -> dict[str, NDArray[Any]]:
        """This FLS's readings, for its first offer of the phase only."""
        if self._readings is None:
            return {}
        ids, vectors = self._readings
        self._readings = None
        return {"reading_ids": ids, "reading_vectors": vectors}

    def _paths_of(self, sources: IntArray) -> tuple[IntArray, IntArray]:
        """The paths of the labels of ``sources``, as (offsets (L + 1,), ids), FLS ids."""
        via, label = self.via_offers[sources], self.via_label[sources]
        # Each label's sender path: where it starts in its offers and how long it is.
        start = np.zeros(len(sources), dtype=np.int64)
        length = np.zeros(len(sources), dtype=np.int64)
        for key in np.unique(via[via >= 0]).tolist():
            rows = via == key
            offsets = self._heard[key].path_offsets
            start[rows] = offsets[label[rows]]
            length[rows] = offsets[label[rows] + 1] - start[rows]
        path_offsets = csr.offsets(length + 1)
        path_ids = np.full(int(path_offsets[-1]), self.fls_id, dtype=np.int64)  # ends each
        for key in np.unique(via[via >= 0]).tolist():
            rows = via == key
            path_ids[csr.ragged_indices(path_offsets[:-1][rows], length[rows])] = self._heard[
                key
            ].path_ids[csr.ragged_indices(start[rows], length[rows])]
        # Offers heard that no unsent label still comes through are done with
        # (looked for now and then: a few rounds' offers are kept anyway).
        if len(self._heard) > _HEARD_KEPT:
            pending = self.via_offers[~self.sent & (self.via_offers >= 0)]
            for key in set(self._heard) - set(np.unique(pending).tolist()):
                del self._heard[key]
        return path_offsets, path_ids

    def hear(self, heard: RoundOffers) -> None:
        """Take a round's offers at once: record results, relax labels through the hops.

        Each source's label becomes the best of its own and every candidate
        (a heard label plus the hop from its sender) under the order
        (primary cost, secondary cost, sender id). That order is total, so the
        outcome is the one of hearing the offers one by one, in any order.
        """
        missing = self._wanted[~self._found[self._wanted]]
        if len(missing):
            mine = _labels_for(self.fls_id, missing, heard.senders, heard.starts, heard.source_ids)
            for label in mine.tolist():
                sender = int(heard.sender_ids[label])
                if sender not in self.results:
                    self._found[sender] = True
                    self.results[sender] = Found(
                        heard.path(label),
                        float(heard.lengths[label]),
                        heard.vectors[label].copy(),
                        float(heard.errors[label]),
                        heard.unbiased[label].copy() if self.fits else None,
                        heard.covariances[label].copy() if self.fits else None,
                    )
        senders, readings = heard.readings_of(self.fls_id)
        if len(senders):
            # The senders' own readings of the hops to this FLS.
            rows = np.searchsorted(self.link_ids, senders)
            known = (rows < len(self.link_ids)) & (
                self.link_ids[np.minimum(rows, len(self.link_ids) - 1)] == senders
            )
            self.link_vectors[rows[known]] = readings[known]
        won_label = np.full(len(self.hops), -1, dtype=np.int64)
        won_link = np.zeros(len(self.hops), dtype=np.int64)
        changed = _relax(
            self.fls_id,
            self.link_ids,
            self.link_weights,
            self.link_errors,
            self.order,
            heard.senders,
            heard.starts,
            heard.source_ids,
            heard.hops,
            heard.lengths,
            heard.errors,
            self.sent,
            self.hops,
            self.length,
            self.error,
            self.pred,
            won_label,
            won_link,
        )
        if not len(changed):
            return
        labels, links = won_label[changed], won_link[changed]
        hop = self.link_vectors[links]
        self.vector[changed] = heard.vectors[labels] + hop
        if self.fit is not None:
            sensor, radius = self.fit
            unbiased, covariance = hop_fit(sensor, radius, hop, self.link_weights[links])
            self.unbiased[changed] = heard.unbiased[labels] + unbiased
            self.covariance[changed] = heard.covariances[labels] + covariance
        key = self._heard_count
        self._heard_count += 1
        self._heard[key] = heard
        self.via_offers[changed] = key
        self.via_label[changed] = labels


def phase_targets(phase: int, blind: IntArray, sweet_results: dict[int, Found]) -> IntArray:
    """A source's targets in ``phase``: blind neighbours (in SD_vis: without S_vis path)."""
    if phase == ANY_VISIBLE:
        return np.array([t for t in blind.tolist() if t not in sweet_results], dtype=np.int64)
    return np.asarray(blind, dtype=np.int64)


@dataclass(frozen=True)
class Estimate:
    """A source's pose relative to one target: status, reason, path and summed vector."""

    target: int
    status: int  # SWEET_PATH, DECAYING_PATH or NO_PATH
    reason: int  # REASON_NONE, REASON_BLOCKED or REASON_NO_SWEET_PATH
    path: tuple[int, ...] = ()
    length: float = float("nan")  # cm
    vector: FloatArray = field(default_factory=lambda: np.full(3, np.nan))  # cm
    radio_path: tuple[int, ...] = ()  # the policy's S_all path (obstruction statistics)
    predicted_error: float = float("nan")  # cm (core.sensor.expected_error); nan without path
    estimator: str = PATH  # what made ``vector``: one of core.fit.SWARM_ESTIMATORS
    covariance: FloatArray | None = None  # (3, 3), cm^2, of ``vector``: a fit's only

    @property
    def hops(self) -> int:
        """Number of hops; 0 without a path."""
        return max(len(self.path) - 1, 0)


def estimate(
    target: int,
    sweet: Found | None,
    radio: Found | None,
    decaying: Found | None,
    sensor: Sensor | None = None,
) -> Estimate:
    """Section 5 of the spec for one target, from its S_vis, S_all and SD_vis results.

    With ``sensor``, the estimate's predicted error follows from its path's
    summed hop errors.
    """
    radio_path = radio.path if radio is not None else ()

    def predicted(found: Found) -> float:
        return float("nan") if sensor is None else float(expected_error(sensor, found.error))

    if sweet is not None:
        return Estimate(
            target,
            SWEET_PATH,
            REASON_NONE,
            sweet.path,
            sweet.length,
            sweet.vector,
            radio_path,
            predicted(sweet),
        )
    reason = REASON_BLOCKED if radio is not None else REASON_NO_SWEET_PATH
    if decaying is not None:
        return Estimate(
            target,
            DECAYING_PATH,
            reason,
            decaying.path,
            decaying.length,
            decaying.vector,
            radio_path,
            predicted(decaying),
        )
    return Estimate(target, NO_PATH, reason, radio_path=radio_path)


class FlsRun:
    """One FLS's part of one discovery run, phase after phase.

    ``targets`` are the FLS's targets as a source: its blind neighbours by
    default, none when it is not a source of the run. ``hop_errors`` (K,) are
    the expected errors of the hops to the view's neighbours.
    """

    def __init__(
        self,
        view: LocalView,
        policy: str,
        width: float,
        id_space: int,
        targets: IntArray | None,
        hop_errors: FloatArray | None = None,
        fit: tuple[Sensor, float] | None = None,
        both_ends: bool = False,
    ) -> None:
        self.view = view
        self.hop_errors = hop_errors
        self.fit = fit
        self.both_ends = both_ends
        self.estimator = PATH if fit is None else LOCAL_LEAST_SQUARES
        self.policy = policy
        self.width = width
        self.id_space = id_space
        self.targets = targets
        self.results: dict[int, dict[int, Found]] = {phase: {} for phase in PHASES}
        self.search: PathSearch | None = None
        self.departed: frozenset[int] = frozenset()

    def start(self, phase: int, departed: frozenset[int]) -> PathSearch:
        """Begin (or restart) ``phase``; its earlier results are dropped."""
        self.departed = departed
        targets = None
        if self.targets is not None:
            wanted = phase_targets(phase, self.targets, self.results[SWEET_VISIBLE])
            wanted = wanted[~np.isin(wanted, list(departed))]
            targets = wanted if len(wanted) else None
        self.search = PathSearch(
            self.view,
            phase,
            self.policy,
            self.width,
            self.id_space,
            targets,
            departed,
            self.hop_errors,
            self.fit,
            self.both_ends,
        )
        self.results[phase] = self.search.results
        return self.search

    def estimates(self, sensor: Sensor | None = None) -> list[Estimate]:
        """The estimate for every target that has not departed, in target order."""
        if self.targets is None:
            return []
        sweet, radio, decaying = (self.results[phase] for phase in PHASES)
        return [
            estimate(target, sweet.get(target), radio.get(target), decaying.get(target), sensor)
            for target in self.targets.tolist()
            if target not in self.departed
        ]

    def fitted(self, sensor: Sensor, radius: float, heard: Heard) -> list[Estimate]:
        """The estimates with each pair's vector from this source's fit of ``heard``.

        As the engine's ``--estimator local-least-squares`` makes them
        (:func:`~swazure_ros.core.fit.window_fit`): the window is the source
        and its radio neighbours; a target that the window does not join to
        the source keeps its path, summed less the known bias.
        """
        estimates = self.estimates(sensor)
        with_path = [one for one in estimates if one.status in (SWEET_PATH, DECAYING_PATH)]
        if not with_path:
            return estimates
        targets = np.array([one.target for one in with_path], dtype=np.int64)
        sweet = np.array([one.status == SWEET_PATH for one in with_path], dtype=bool)
        vectors, covariances, _ = window_fit(
            sensor, radius, radio_window(self.view), heard, targets, sweet
        )
        fits: dict[int, Estimate] = {}
        for one, vector, covariance in zip(with_path, vectors, covariances, strict=True):
            if np.isnan(vector).any():
                phase = SWEET_VISIBLE if one.status == SWEET_PATH else ANY_VISIBLE
                found = self.results[phase][one.target]
                if found.unbiased is None or found.covariance is None:
                    continue  # a label from a run that does not fit (forged): the path's own
                vector, covariance = found.unbiased, found.covariance
            fits[one.target] = replace(
                one,
                vector=vector,
                covariance=covariance,
                predicted_error=float(np.sqrt(np.trace(covariance))),
                estimator=LOCAL_LEAST_SQUARES,
            )
        return [fits.get(one.target, one) for one in estimates]


def radio_window(view: LocalView) -> IntArray:
    """(W,) the FLSs an FLS hears: itself, then its radio neighbours (blind and sweet), ids."""
    radio = np.isin(view.range_class, (BLIND, SWEET))
    return np.concatenate([[view.fls_id], view.other[radio]]).astype(np.int64)


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


@dataclass(frozen=True)
class Broadcast:
    """An FLS's offer of one round, for the radio (a PathOffer message)."""

    run_id: int
    phase: int
    round: int
    sender: int
    offer: Offer


@dataclass(frozen=True)
class Report:
    """A source's estimates at the end of a run (a PoseEstimates message)."""

    run_id: int
    source: int
    estimates: list[Estimate]


class Participant:
    """One FLS's part of every discovery run: controls and offers in, broadcasts and reports out.

    ``view()`` tells what the FLS knows of its neighbours when a run starts;
    ``sensor`` and ``radius`` (cm) what each hop may cost (bucket widths, hop
    errors), and ``id_space`` bounds the FLS ids. ``readings`` holds what the
    FLS has heard of other FLSs' cameras: a source of a fitting run reports
    once it has heard its whole window (:meth:`waiting_reports`).
    """

    def __init__(
        self,
        fls_id: int,
        view: Callable[[], LocalView],
        sensor: Sensor,
        radius: float,
        id_space: int,
        readings: ReadingsBook | None = None,
    ) -> None:
        self.fls_id = fls_id
        self._view = view
        self.sensor = sensor
        self.radius = radius
        self.id_space = id_space
        self.readings = ReadingsBook() if readings is None else readings
        self.runs: dict[int, FlsRun] = {}
        # Fitting runs that ended while this source had not heard its whole window.
        self.waiting: dict[int, FlsRun] = {}
        # Rounds count on across phases and restarts; buckets count from the phase's start.
        self._first_round: dict[int, int] = {}

    def on_control(
        self, control: Control, heard: RoundOffers | None = None
    ) -> Broadcast | Report | None:
        """Follow the round clock: START a phase, broadcast a ROUND's labels, report at END.

        ``heard`` are the offers of the rounds since the last control, taken
        first: a label of round k changes only buckets after k, which nobody
        broadcasts before round k + 1.
        """
        run_id = control.run_id
        if control.command == START:
            run = self.runs.get(run_id)
            if run is None:
                while len(self.runs) >= RUNS_KEPT:  # the oldest run is over or forged
                    oldest = next(iter(self.runs))
                    del self.runs[oldest]
                    self._first_round.pop(oldest, None)
                run = self.runs[run_id] = self._new_run(control)
            run.start(control.phase, frozenset(control.departed_ids))
            self._first_round[run_id] = control.round
            return None
        if control.command == ROUND:
            run = self.runs.get(run_id)
            if run is None or run.search is None:
                return None
            if heard is not None:
                run.search.hear(heard)
            run.search.close(np.asarray(control.finished_ids, dtype=np.int64))
            offer = run.search.offer(control.round - self._first_round.get(run_id, 0))
            return Broadcast(run_id, control.phase, control.round, self.fls_id, offer)
        if control.command == END:
            run = self.runs.pop(run_id, None)
            self._first_round.pop(run_id, None)
            if run is not None and run.search is not None and heard is not None:
                run.search.hear(heard)
            if run is not None and run.targets is not None:
                if run.estimator == PATH:
                    return Report(run_id, self.fls_id, run.estimates(self.sensor))
                if self.readings.has(radio_window(run.view)):
                    return self._fitted(run_id, run)
                self.waiting[run_id] = run  # its readings are still on their way
        return None

    def waiting_reports(self, at_deadline: bool = False) -> list[Report]:
        """The reports of fitting runs whose source has now heard its whole window.

        ``at_deadline``: every waiting run reports, fitted to what was heard.
        """
        reports = []
        for run_id, run in list(self.waiting.items()):
            if at_deadline or self.readings.has(radio_window(run.view)):
                del self.waiting[run_id]
                reports.append(self._fitted(run_id, run))
        return reports

    def _fitted(self, run_id: int, run: FlsRun) -> Report:
        """Run ``run_id``'s report, fitted to what this FLS has heard of its window."""
        heard = self.readings.heard(radio_window(run.view))
        return Report(run_id, self.fls_id, run.fitted(self.sensor, self.radius, heard))

    def abandon(self) -> list[Report]:
        """Drop every run (their coordinator is gone); a source's targets are ABORTED."""
        reports = [
            Report(
                run_id,
                self.fls_id,
                [
                    Estimate(target, ABORTED, REASON_COORDINATOR_LOST)
                    for target in run.targets.tolist()
                    if target not in run.departed
                ],
            )
            for run_id, run in sorted({**self.runs, **self.waiting}.items())
            if run.targets is not None and len(run.targets)
        ]
        self.runs.clear()
        self.waiting.clear()
        self._first_round.clear()
        return reports

    def _new_run(self, control: Control) -> FlsRun:
        view = self._view()
        targets: IntArray | None = view.blind
        if control.source_ids:
            sources = np.asarray(control.source_ids, dtype=np.int64)
            mine = sources == self.fls_id
            if not mine.any():
                targets = None
            elif control.target_ids:
                # On demand, a source answers for its blind neighbours only.
                asked = np.asarray(control.target_ids, dtype=np.int64)[mine]
                targets = asked[np.isin(asked, view.blind)]
        width = bucket_width(self.sensor, self.radius, control.policy)
        hop_errors = hop_error(self.sensor, view.distance, self.radius)
        fit = (self.sensor, self.radius) if control.estimator == LOCAL_LEAST_SQUARES else None
        both_ends = reads_both_ends(self.sensor)
        return FlsRun(
            view, control.policy, width, self.id_space, targets, hop_errors, fit, both_ends
        )


def evaluation_of(
    hood: Neighbourhood, policy: str, found: dict[int, list[Estimate]]
) -> Evaluation:
    """The evaluation that sources' estimates ({source id: estimates}) make, in engine pair order.

    Only the pairs that were reported count (a departed FLS reports none and
    is nobody's target); errors and obstruction follow from the geometry.
    """
    ids = hood.swarm.cloud_index
    by_pair = {
        (source, one.target): one for source, estimates in found.items() for one in estimates
    }
    source, target = ordered_blind_pairs(hood.pairs)
    keys = zip(ids[source].tolist(), ids[target].tolist(), strict=True)
    reported = [by_pair.get(key) for key in keys]
    keep = np.array([one is not None for one in reported], dtype=bool)
    source, target = source[keep], target[keep]
    kept = [one for one in reported if one is not None]
    count = len(kept)

    def indices(path: tuple[int, ...]) -> list[int]:
        return np.searchsorted(ids, path).tolist() if path else []

    status = np.array([one.status for one in kept], dtype=np.int8)
    reason = np.array([one.reason for one in kept], dtype=np.int8)
    paths = paths_from_rows(
        count,
        {m: indices(one.path) for m, one in enumerate(kept) if one.status != NO_PATH},
        {m: one.length for m, one in enumerate(kept) if one.status != NO_PATH},
    )
    vectors = np.array([one.vector for one in kept], dtype=np.float64).reshape(count, 3)
    connected = np.array([bool(one.radio_path) for one in kept], dtype=bool)
    radio_rows = [indices(one.radio_path) for one in kept if one.radio_path]
    radio = paths_from_rows(len(radio_rows), dict(enumerate(radio_rows)))
    pairs = pair_results(hood, source, target, status, reason, paths, vectors, radio, connected)
    fitted = np.array([one.covariance is not None for one in kept], dtype=bool)
    if fitted.any():
        # The fit's estimates carry their covariance and predicted error (core.fit.refine).
        covariance = np.full((count, 3, 3), np.nan)
        covariance[fitted] = [one.covariance for one in kept if one.covariance is not None]
        predicted = np.array([one.predicted_error for one in kept], dtype=np.float64)
        pairs = pairs.with_estimates(vectors, predicted_error=predicted, covariance=covariance)
    summary = summarise(hood, policy, pairs)
    if fitted.any():
        summary["estimator"] = summary["parameters"]["estimator"] = LOCAL_LEAST_SQUARES
        summary["fit"] = consistency(pairs)
    return Evaluation(hood, policy, pairs, summary)
