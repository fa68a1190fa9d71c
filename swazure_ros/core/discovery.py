"""Distributed path discovery: one FLS's part of the protocol of docs/protocol.md.

Every FLS runs a :class:`PathSearch` per phase of a discovery run. It holds
the FLS's best path label for each source: the path from the source to this
FLS, its hop count and length, and the measured hop vectors summed from the
source. In round k of a phase an FLS broadcasts the labels whose bucket is k
(:func:`bucket_width`); its neighbours relax them through their own hop.

Buckets make every broadcast label final. Every hop is at least
``sweet_min`` long and adds one hop, so a label can only be improved by a
label of a lower bucket, which was broadcast in an earlier round. Each FLS
therefore broadcasts each source's label once, and keeps, among equal costs,
the label whose sender has the smallest FLS id: the predecessor rule of
:mod:`.paths`, so the distributed search picks the core engine's paths.

:func:`estimate` turns one target's phase results into the pair's status,
reason and path, as section 5 of the spec orders the phases.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .evaluate import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
    Evaluation,
    Neighbourhood,
    pair_results,
    summarise,
)
from .neighbours import ordered_blind_pairs
from .observe import Observations
from .paths import FEWEST_HOPS, check_policy, paths_from_rows
from .sensor import BLIND, DECAYING, SWEET

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

# Phases; the values equal swazure_interfaces/DiscoveryControl's PHASE_*.
SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE = 0, 1, 2
PHASES = (SWEET_VISIBLE, SWEET_ALL, ANY_VISIBLE)
PHASE_NAMES = ("S_vis", "S_all", "SD_vis")

#: Bucket widths sit this fraction below the shortest hop, so that rounding in
#: a sum of lengths never puts a label in the bucket of the label it extends.
_BUCKET_MARGIN = 1e-9


def bucket_width(sweet_min: float, policy: str) -> float:
    """Cost per round: one hop for fewest-hops, just under ``sweet_min`` cm for shortest-length."""
    if check_policy(policy) == FEWEST_HOPS:
        return 1.0
    if not sweet_min > 0:
        raise ValueError(f"sweet_min must be positive for shortest-length, got {sweet_min}")
    return sweet_min * (1.0 - _BUCKET_MARGIN)


@dataclass(frozen=True)
class LocalView:
    """What one FLS knows of its neighbours (K of them) when a discovery run starts."""

    fls_id: int
    other: IntArray  # (K,), FLS ids
    range_class: NDArray[np.int8]  # (K,), BLIND, SWEET or DECAYING
    visible: NDArray[np.bool_]  # (K,), camera line of sight
    distance: FloatArray  # (K,), tracking distance by radio, cm
    vector: FloatArray  # (K, 3), measured vector to the neighbour, cm; NaN without a reading

    @property
    def blind(self) -> IntArray:
        """(B,) ids of the blind neighbours: the targets of this FLS as a source."""
        return np.asarray(self.other[self.range_class == BLIND], dtype=np.int64)

    def hop_mask(self, phase: int) -> NDArray[np.bool_]:
        """(K,) the neighbours this FLS relays from in ``phase``."""
        sweet = self.range_class == SWEET
        if phase == SWEET_VISIBLE:
            return np.asarray(sweet & self.visible)
        if phase == SWEET_ALL:
            return np.asarray(sweet)
        if phase == ANY_VISIBLE:
            return np.asarray((sweet | (self.range_class == DECAYING)) & self.visible)
        raise ValueError(f"unknown discovery phase {phase}")


def local_view(seen: Observations, ids: IntArray, fls: int) -> LocalView:
    """The view of the FLS at swarm index ``fls``, with neighbours as FLS ids."""
    rows = seen.rows(fls)
    return LocalView(
        fls_id=int(ids[fls]),
        other=ids[seen.other[rows]],
        range_class=seen.range_class[rows],
        visible=seen.visible[rows],
        distance=seen.distance[rows],
        vector=seen.vector[rows],
    )


@dataclass
class Offer:
    """One FLS's labels of one round (L of them), as a PathOffer message carries them."""

    source_ids: IntArray  # (L,)
    hops: IntArray  # (L,)
    lengths: FloatArray  # (L,), cm
    vectors: FloatArray  # (L, 3), cm, summed from the source to the sender
    path_offsets: IntArray  # (L + 1,)
    path_ids: IntArray
    pending: bool = False
    finished: bool = False

    def __len__(self) -> int:
        return len(self.source_ids)

    def path(self, label: int) -> tuple[int, ...]:
        """Path of label ``label``, FLS ids from its source to the sender."""
        start, stop = self.path_offsets[label], self.path_offsets[label + 1]
        return tuple(int(fls) for fls in self.path_ids[start:stop])


@dataclass(frozen=True)
class Found:
    """A path from a source to one FLS: ids, hops, length (cm) and summed vector (3,), cm."""

    path: tuple[int, ...]
    length: float
    vector: FloatArray

    @property
    def hops(self) -> int:
        """Number of hops."""
        return len(self.path) - 1


class PathSearch:
    """One FLS's labels in one phase of a discovery run.

    ``id_space`` bounds the FLS ids (ids are below it). ``targets`` makes this
    FLS a source that searches for them; ``departed`` FLSs are not relayed from.
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
    ) -> None:
        self.fls_id = view.fls_id
        self.fewest_hops = check_policy(policy) == FEWEST_HOPS
        self.width = width
        hop = view.hop_mask(phase) & ~np.isin(view.other, list(departed))
        # The hop sender -> self is measured by this FLS's camera the other way round.
        self.links: dict[int, tuple[float, FloatArray]] = {
            int(other): (float(distance), -vector)
            for other, distance, vector in zip(
                view.other[hop], view.distance[hop], view.vector[hop], strict=True
            )
        }
        self.hops = np.full(id_space, np.inf)
        self.length = np.full(id_space, np.inf)
        self.pred = np.full(id_space, np.iinfo(np.int64).max, dtype=np.int64)
        self.vector = np.full((id_space, 3), np.nan)
        self.sent = np.zeros(id_space, dtype=bool)
        self.closed = np.zeros(id_space, dtype=bool)  # sources whose search has ended
        self.paths: dict[int, tuple[int, ...]] = {}
        self.targets = frozenset(int(t) for t in targets) if targets is not None else frozenset()
        self.results: dict[int, Found] = {}
        self.messages_heard = 0
        if targets is not None:
            me = self.fls_id
            self.hops[me], self.length[me], self.pred[me] = 0.0, 0.0, me
            self.vector[me] = 0.0
            self.paths[me] = (me,)

    @property
    def finished(self) -> bool:
        """True when this FLS, as a source, has a result for every target."""
        return bool(self.targets) and len(self.results) == len(self.targets)

    def _buckets(self, sources: IntArray) -> FloatArray:
        primary = self.hops[sources] if self.fewest_hops else self.length[sources]
        return np.asarray(np.floor(primary / self.width))

    def close(self, sources: IntArray) -> None:
        """Stop relaying the labels of ``sources`` (their searches ended)."""
        self.closed[np.asarray(sources, dtype=np.int64)] = True

    def offer(self, round_: int) -> Offer:
        """The labels due in round ``round_`` (each is final); they count as sent."""
        labelled = np.flatnonzero(np.isfinite(self.hops) & ~self.sent & ~self.closed)
        due = labelled[self._buckets(labelled) <= round_]
        self.sent[due] = True
        paths = [self.paths[int(source)] for source in due]
        counts = np.array([len(path) for path in paths], dtype=np.int64)
        return Offer(
            source_ids=due.astype(np.int64),
            hops=self.hops[due].astype(np.int64),
            lengths=self.length[due],
            vectors=self.vector[due],
            path_offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            path_ids=np.fromiter(
                (fls for path in paths for fls in path), dtype=np.int64, count=int(counts.sum())
            ),
            pending=len(due) < len(labelled),
            finished=self.finished,
        )

    def hear(self, sender: int, offer: Offer) -> None:
        """Take a neighbour's offer: record results, relax labels through the hop from it."""
        self.messages_heard += 1
        if not len(offer):
            return
        if sender in self.targets and sender not in self.results:
            mine = np.flatnonzero(offer.source_ids == self.fls_id)
            if len(mine):
                label = int(mine[0])
                self.results[sender] = Found(
                    offer.path(label), float(offer.lengths[label]), offer.vectors[label].copy()
                )
        link = self.links.get(sender)
        if link is None:
            return
        weight, hop_vector = link
        sources = offer.source_ids
        # Sums in path order, as the engine sums them: cost so far plus this hop.
        new_hops = offer.hops.astype(np.float64) + 1.0
        new_length = offer.lengths + weight
        old_hops, old_length, old_pred = (
            self.hops[sources],
            self.length[sources],
            self.pred[sources],
        )
        if self.fewest_hops:
            new1, new2, old1, old2 = new_hops, new_length, old_hops, old_length
        else:
            new1, new2, old1, old2 = new_length, new_hops, old_length, old_hops
        better = (new1 < old1) | (
            (new1 == old1) & ((new2 < old2) | ((new2 == old2) & (sender < old_pred)))
        )
        better &= ~self.sent[sources] & (sources != self.fls_id)
        for label in np.flatnonzero(better).tolist():
            source = int(sources[label])
            self.hops[source] = new_hops[label]
            self.length[source] = new_length[label]
            self.pred[source] = sender
            self.vector[source] = offer.vectors[label] + hop_vector
            self.paths[source] = (*offer.path(label), self.fls_id)


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

    @property
    def hops(self) -> int:
        """Number of hops; 0 without a path."""
        return max(len(self.path) - 1, 0)


def estimate(
    target: int,
    sweet: Found | None,
    radio: Found | None,
    decaying: Found | None,
) -> Estimate:
    """Section 5 of the spec for one target, from its S_vis, S_all and SD_vis results."""
    radio_path = radio.path if radio is not None else ()
    if sweet is not None:
        return Estimate(
            target, SWEET_PATH, REASON_NONE, sweet.path, sweet.length, sweet.vector, radio_path
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
        )
    return Estimate(target, NO_PATH, reason, radio_path=radio_path)


class FlsRun:
    """One FLS's part of one discovery run, phase after phase.

    ``targets`` are the FLS's targets as a source: its blind neighbours by
    default, none when it is not a source of the run.
    """

    def __init__(
        self,
        view: LocalView,
        policy: str,
        width: float,
        id_space: int,
        targets: IntArray | None,
    ) -> None:
        self.view = view
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
            self.view, phase, self.policy, self.width, self.id_space, targets, departed
        )
        self.results[phase] = self.search.results
        return self.search

    def estimates(self) -> list[Estimate]:
        """The estimate for every target that has not departed, in target order."""
        if self.targets is None:
            return []
        sweet, radio, decaying = (self.results[phase] for phase in PHASES)
        return [
            estimate(target, sweet.get(target), radio.get(target), decaying.get(target))
            for target in self.targets.tolist()
            if target not in self.departed
        ]


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
    return Evaluation(hood, policy, pairs, summarise(hood, policy, pairs))


@dataclass
class RoundTally:
    """What the coordinator knows of one round: who broadcast, what they hold, who delivered."""

    expected: frozenset[int]  # FLS ids that take part
    hosts: int  # processes whose radio must acknowledge the round
    senders: set[int] = field(default_factory=set)
    labels: int = 0
    pending: bool = False
    finished: set[int] = field(default_factory=set)
    acks: set[str] = field(default_factory=set)

    def hear(self, sender: int, labels: int, pending: bool, finished: bool) -> None:
        """Count one FLS's broadcast of this round."""
        if sender not in self.expected or sender in self.senders:
            return
        self.senders.add(sender)
        self.labels += labels
        self.pending |= pending
        if finished:
            self.finished.add(sender)

    def ack(self, host: str) -> None:
        """Count one process's acknowledgement that it delivered every broadcast."""
        self.acks.add(host)

    @property
    def complete(self) -> bool:
        """Every FLS broadcast and every process delivered."""
        return len(self.senders) == len(self.expected) and len(self.acks) >= self.hosts

    @property
    def silent(self) -> frozenset[int]:
        """FLSs that have not broadcast (yet)."""
        return self.expected - self.senders

    @property
    def quiet(self) -> bool:
        """Nothing was sent and nothing is due later: the phase is over."""
        return self.labels == 0 and not self.pending


def sweet_hop(
    others: IntArray,
    range_class: NDArray[np.int8],
    vectors: FloatArray,
    tracking: FloatArray,
    next_fls: int,
) -> tuple[FloatArray, float] | None:
    """An FLS's own measured vector (3,) and measured tracking distance to ``next_fls``, cm.

    ``others`` (K,) are the FLSs it measures now, with their range classes,
    vectors (K, 3) and tracking distances (K,). None unless ``next_fls`` is
    among them as a sweet neighbour: a path walk crosses sweet hops only.
    """
    where = np.flatnonzero(others == next_fls)
    if len(where) == 0 or range_class[where[0]] != SWEET:
        return None
    return np.asarray(vectors[where[0]], dtype=np.float64), float(tracking[where[0]])
