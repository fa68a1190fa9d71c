"""The radio of one process: what its FLSs hear of a round, and its acknowledgement.

A radio broadcast reaches the FLSs within radio range of the sender (blind
or sweet range, line of sight ignored; spec section 4). A process that hosts
some of the swarm's FLSs hears every broadcast once (:meth:`RadioHub.on_offer`)
and keeps the round's offers; at the coordinator's next control it hands
them, in one :class:`~.discovery.messages.RoundOffers`, to every local FLS that has
not departed (:meth:`RadioHub.on_control`). Each FLS takes from it only the
labels of its own neighbours, every one of them within its radio range, so
it hears exactly what a real radio would bring it. Once the process has
every offer of a round that reaches it (one per live FLS in the radio cells
it hears, ``audible``; protocol.cells), it acknowledges the round
(:class:`Ack`), so that the coordinator can open the next one; before that,
it tells the coordinator which of its own FLSs spoke (:class:`Sent`).

An offer found false (a forgery: protocol.plausible) counts for nobody. Offers
are checked in one batch a round, just before the ack that they would
complete, and whenever a sender's offers fill its slots: a forged offer can
neither make a process acknowledge a round before the real sender's offer is
in, nor take the place of that offer.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import IntArray
from ..core.errors import MessageError
from .discovery.messages import (
    END,
    ROUND,
    START,
    Broadcast,
    Control,
    FitBlock,
    FitOffer,
    Offer,
    RoundOffers,
)
from .discovery.participant import RUNS_KEPT
from .plausible import REASONS
from .radio_loss import Delivery, RadioLoss
from .swarm_fit import process_sums

#: Offers of one sender in one round that a process keeps, none of them known false (the
#: first counts; a second is kept in case the first is a plausible forgery).
OFFERS_PER_SENDER = 2
#: Runs whose last control a process remembers, to know a replayed control for one.
CONTROLS_KEPT = 64
#: Offers a process keeps for runs it has not started: a round of the largest
#: published shape is 3,720 offers.
EARLY_OFFERS = 16_384


@dataclass(frozen=True)
class Sent:
    """What a process's own FLSs broadcast in one round, for the coordinator's tally."""

    senders: tuple[int, ...] = ()  # FLS ids, ascending
    labels: int = 0  # labels in their offers, summed
    pending: tuple[int, ...] = ()  # those that hold labels due in a later round
    finished: tuple[int, ...] = ()  # those whose search, as a source, has ended
    bytes: int = 0  # the size of their offers on the wire, summed
    # The FIT phase (protocol.swarm_fit): their shares of the swarm's sums, summed exactly
    # per column; the largest move; whether Huber's and the rejecting weights stayed.
    fit_sums: tuple[float, ...] = ()
    fit_moved: float = 0.0
    fit_same: tuple[bool, bool] = (True, True)
    # Sources whose labels they hold beyond the pass's reach (buckets.reach_rounds), ascending.
    beyond: tuple[int, ...] = ()
    searching: tuple[int, ...] = ()  # those that search as sources: their own label offered
    label_bytes: int = 0  # the memory their labels take, summed (LabelTable.row_bytes)


@dataclass(frozen=True)
class Ack:
    """A process heard every offer of one round that it hears (a RoundAck message)."""

    run_id: int
    phase: int
    round: int
    heard: int  # offers of the round heard
    repairs: int = 0  # repair requests and resends a lossy radio needed
    lost: int = 0  # deliveries to this process's FLSs lost for good
    latency: float = 0.0  # s the round's deliveries took: the ack goes out that late


class _Said(NamedTuple):
    """What one local FLS's broadcast of a round tells the coordinator's tally."""

    labels: int
    pending: bool
    finished: bool
    size: int  # bytes on the wire
    label_bytes: int  # its label row's memory (Offer.label_bytes)


@dataclass(eq=False)
class _Kept:
    """One offer a process keeps for a round, until the round's next control hands it over."""

    sender: int
    offer: Offer
    phase: int | None  # the phase it says it is of (None: its round's)
    trusted: bool  # a local FLS's own, or checked and found possibly true


@dataclass
class _RoundHeard:
    """The offers of one round that a process keeps, and the senders they count for."""

    kept: list[_Kept] = field(default_factory=list)
    # Local FIT offers kept whole, a row a sender; their senders have no entry in ``kept``
    # when the block comes (RadioHub.on_block).
    blocks: list[FitBlock] = field(default_factory=list)
    senders: Counter[int] = field(default_factory=Counter)  # sender -> offers kept
    phase: int | None = None  # the round's, once its ROUND control came
    # The senders whose offer completes the round here (None: any), once its ROUND came.
    countable: frozenset[int] | None = None
    counted: int = 0  # senders of ``countable`` with an offer kept

    def counts(self, sender: int) -> bool:
        """Whether ``sender``'s offer counts toward this round's ack here."""
        return self.countable is None or sender in self.countable

    def keep(self, entry: _Kept) -> None:
        """Keep ``entry``; its sender counts from its first offer kept."""
        self.kept.append(entry)
        self.senders[entry.sender] += 1
        if self.senders[entry.sender] == 1 and self.counts(entry.sender):
            self.counted += 1

    def keep_block(self, block: FitBlock) -> None:
        """Keep ``block``, none of whose senders has an offer kept: each counts from now."""
        self.blocks.append(block)
        senders = block.senders.tolist()
        self.senders.update(senders)
        if self.countable is None:
            self.counted += len(senders)
        else:
            self.counted += len(self.countable.intersection(senders))

    def discard(self, false: list[_Kept]) -> None:
        """Forget the offers ``false``: their senders count only by offers still kept."""
        gone = {id(entry) for entry in false}
        self.kept = [entry for entry in self.kept if id(entry) not in gone]
        for entry in false:
            self.senders[entry.sender] -= 1
            if not self.senders[entry.sender]:
                del self.senders[entry.sender]
                if self.counts(entry.sender):
                    self.counted -= 1

    def clock(self, phase: int, countable: frozenset[int] | None) -> None:
        """The round's ROUND came: its phase, and who completes it here."""
        self.phase, self.countable = phase, countable
        self.counted = sum(1 for sender in self.senders if self.counts(sender))

    def first_offers(self) -> list[tuple[int, Offer]]:
        """(sender, offer) of each sender's first offer kept, in the order heard."""
        first: dict[int, Offer] = {}
        for entry in self.kept:
            first.setdefault(entry.sender, entry.offer)
        if first and self.blocks:  # a block's senders offered first: a later one is second
            for block in self.blocks:
                for sender in block.senders.tolist():
                    first.pop(sender, None)
        return list(first.items())


class RadioHub:
    """A round's offers, the local FLSs that take them, and when a round is heard.

    ``local`` holds the ids of the FLSs this process hosts (it may shrink as
    FLSs stop).
    """

    def __init__(
        self,
        local: Collection[int],
        loss: RadioLoss | None = None,
        neighbours: Callable[[int], IntArray] | None = None,
        check: Callable[[RoundOffers, int], NDArray[np.int8]] | None = None,
        check_readings: Callable[[int, Offer], str | None] | None = None,
        audible: Callable[[int], IntArray] | None = None,
    ) -> None:
        self._local = local
        # audible(phase): the ids of the FLSs whose broadcasts of ``phase`` this process
        # hears (its radio cells'); None: every FLS's, as many as a control expects.
        self._audible = audible
        self._loss = loss if loss is not None and loss.active else None
        # neighbours(fls): the FLSs whose offers that FLS takes (its view's).
        self._neighbours = neighbours
        # check(offers, phase): why each label heard cannot be true, a code of
        # plausible.REASONS (0: it may be), checked once a round over every offer heard.
        self._check = check
        # check_readings(sender, offer): why the readings an offer carries cannot be true.
        self._check_readings = check_readings
        #: (sender, why) of the offers dropped as implausible, for the caller to count.
        self.rejected: list[tuple[int, str]] = []
        self._pairs: dict[int, tuple[IntArray, IntArray]] = {}  # run -> (sender, receiver)
        self._departed: dict[int, frozenset[int]] = {}
        self._first_round: dict[int, int] = {}
        # (run, round) -> its ROUND, and the offers it brings this process, until acked.
        self._rounds: dict[tuple[int, int], tuple[Control, int]] = {}
        # (run, round) -> what the local FLSs broadcast, by sender.
        self._sent: dict[tuple[int, int], dict[int, _Said]] = {}
        # (run, round) -> what the local FLSs said to the coordinator in the FIT phase.
        self._fit_sent: dict[tuple[int, int], dict[int, FitOffer]] = {}
        # (run, round) -> the blocks of FIT offers the local FLSs made together, and bytes.
        self._blocks_sent: dict[tuple[int, int], list[tuple[FitBlock, int]]] = {}
        # The sources its FLSs' offers of a round held beyond the reach, and those of its
        # FLSs that offered their own label (searching sources), by (run, round).
        self._beyond_sent: dict[tuple[int, int], list[IntArray]] = {}
        self._searching_sent: dict[tuple[int, int], set[int]] = {}
        # (run, round) -> the offers kept of that round, until a later control hands them over.
        self._heard: dict[tuple[int, int], _RoundHeard] = {}
        #: run -> (round, command) of its last control, for the newest CONTROLS_KEPT runs.
        self._last_control: dict[int, tuple[int, int]] = {}
        #: Offers of runs not started here yet (run, round, sender, offer, phase), oldest
        #: dropped first.
        self._early: deque[tuple[int, int, int, Offer, int | None]] = deque(maxlen=EARLY_OFFERS)

    def abandon(self) -> None:
        """Forget every run (their coordinator is gone)."""
        self._pairs.clear()
        self._departed.clear()
        self._first_round.clear()
        self._rounds.clear()
        self._heard.clear()
        self._sent.clear()
        self._fit_sent.clear()
        self._blocks_sent.clear()
        self._beyond_sent.clear()
        self._searching_sent.clear()
        self._early.clear()

    def departed(self, run_id: int) -> frozenset[int]:
        """The FLSs declared gone in run ``run_id``'s current phase."""
        return self._departed.get(run_id, frozenset())

    def on_control(self, control: Control) -> tuple[list[int], Ack | None, RoundOffers | None]:
        """(the local FLSs to hand ``control`` to, the round's ack if now heard, the offers).

        The offers are those of the rounds before ``control.round``, for a
        ROUND or the END, less those of senders with a label that the hub's
        ``check`` finds cannot be true (listed in :attr:`rejected`); a START
        drops those of the phase before. A run's
        controls come in strictly increasing (round, command) order: one that
        does not is a replay of an earlier one (MessageError).
        """
        run = control.run_id
        order = (control.round, control.command)
        if order <= self._last_control.get(run, (-1, -1)):
            raise MessageError(
                f"control {order} of run {run} is not after {self._last_control[run]}"
            )
        self._last_control[run] = order
        while len(self._last_control) > CONTROLS_KEPT:
            del self._last_control[next(iter(self._last_control))]
        heard = None
        if control.command == START:
            if run not in self._first_round and len(self._first_round) >= RUNS_KEPT:
                oldest = next(iter(self._first_round))  # over, or made up by a peer
                self._departed.pop(oldest, None)
                self._pairs.pop(oldest, None)
                self._first_round.pop(oldest)
                self._forget(oldest, rounds=True)
            self._departed[run] = frozenset(control.departed_ids)
            if self._loss is not None and self._neighbours is not None:
                self._pairs[run] = self._radio_pairs()
            self._first_round[run] = control.round
            self._forget(run, rounds=False)
            self._take_early(run)
        elif run not in self._first_round:
            # A run this process never started (or ended): nothing to hand over or ack.
            return [], None, None
        else:
            # Each sender's first offer of each round that may be true; normally all there are.
            done = sorted(key for key in self._heard if key[0] == run and key[1] < control.round)
            entries, blocks = [], []
            for key in done:
                round_heard = self._heard.pop(key)
                self._settle(round_heard, control.phase)
                entries += round_heard.first_offers()
                blocks += round_heard.blocks
            heard = RoundOffers.of(entries, blocks)
        departed = self.departed(run)
        recipients = [fls_id for fls_id in self._local if fls_id not in departed]
        ack = None
        if control.command == ROUND:
            expected, countable = self._expected(control, departed)
            self._rounds[(run, control.round)] = (control, expected)
            self._heard.setdefault((run, control.round), _RoundHeard()).clock(
                control.phase, countable
            )
            ack = self._acknowledge(run, control.round)
        elif control.command == END:
            self._departed.pop(run, None)
            self._pairs.pop(run, None)
            self._first_round.pop(run, None)
            self._forget(run, rounds=True)
        return recipients, ack, heard

    def _expected(
        self, control: Control, departed: frozenset[int]
    ) -> tuple[int, frozenset[int] | None]:
        """(the offers of ``control``'s round this process will hear, their senders).

        One offer per live FLS it hears; without ``audible``, as many as the
        control expects, from any FLS not departed (senders None).
        """
        if self._audible is None:
            return control.expected, None
        countable = frozenset(self._audible(control.phase).tolist()) - departed
        return len(countable), countable

    def sent_all(self, offers: Sequence[Broadcast], sizes: Sequence[int] | None = None) -> None:
        """Local FLSs broadcast ``offers`` (``sizes`` bytes each, 0 by default): what each
        tells the coordinator's tally, recorded in one pass. See :meth:`take_sent`.

        A sender's first offer of a round counts for it; its fit and the sources it holds
        beyond the pass's reach are kept from each.
        """
        if not offers:
            return
        key = (offers[0].run_id, offers[0].round)
        said = self._sent.setdefault(key, {})
        for index, out in enumerate(offers):
            sender, offer = out.sender, out.offer
            if (out.run_id, out.round) != key:
                key = (out.run_id, out.round)
                said = self._sent.setdefault(key, {})
            if sender not in said:
                size = 0 if sizes is None else sizes[index]
                labels = len(offer.source_ids)
                said[sender] = _Said(
                    labels, bool(offer.pending), bool(offer.finished), size, offer.label_bytes
                )
            if offer.fit is not None:
                self._fit_sent.setdefault(key, {}).setdefault(sender, offer.fit)
            if len(offer.beyond_ids):
                self._beyond_sent.setdefault(key, []).append(offer.beyond_ids)
            if len(offer) and np.any(offer.source_ids == sender):  # its own label: it searches
                self._searching_sent.setdefault(key, set()).add(sender)

    def sent_block(self, block: FitBlock, size: int = 0) -> None:
        """Local FLSs broadcast the offers of ``block`` (``size`` bytes in all on the wire):
        :meth:`sent_all` of its rows, in one. Its senders have no other offer of the round."""
        self._blocks_sent.setdefault((block.run_id, block.round), []).append((block, size))

    def take_sent(self, run_id: int, round_: int) -> Sent:
        """What the local FLSs broadcast in round ``round_``, for the coordinator's tally.

        Taken once the round's control has reached every local FLS, and told
        to the coordinator at once, before this process has heard the round:
        an FLS silent elsewhere must not hide who spoke here.
        """
        sent = self._sent.pop((run_id, round_), {})
        alone = sorted(sent)
        told = [sent[sender] for sender in alone]
        fits = self._fit_sent.pop((run_id, round_), {})
        said = [fits[sender] for sender in alone if sender in fits]
        blocks = self._blocks_sent.pop((run_id, round_), [])
        senders = tuple(alone)
        if blocks:  # a block's rows are offers as :meth:`sent_all` records them: no label
            together = [block.senders for block, _ in blocks]
            senders = tuple(
                np.union1d(np.asarray(alone, dtype=np.int64), np.concatenate(together)).tolist()
            )
        partials = [one.partials for one in said if len(one.partials)]
        partials += [block.partials for block, _ in blocks if block.partials.size]
        beyond = self._beyond_sent.pop((run_id, round_), [])
        return Sent(
            senders,
            sum(one.labels for one in told),
            tuple(sender for sender, one in zip(alone, told, strict=True) if one.pending),
            tuple(sender for sender, one in zip(alone, told, strict=True) if one.finished),
            sum(one.size for one in told) + sum(size for _, size in blocks),
            process_sums(partials),
            max((one.moved for one in said), default=0.0),
            (all(one.same[0] for one in said), all(one.same[1] for one in said)),
            tuple(np.unique(np.concatenate(beyond)).tolist()) if beyond else (),
            tuple(sorted(self._searching_sent.pop((run_id, round_), ()))),
            sum(one.label_bytes for one in told),
        )

    def _settle(self, heard: _RoundHeard, fallback: int | None = None) -> None:
        """Check the offers of a round not checked yet; drop those found false (:attr:`rejected`).

        Only offers from other processes are ever unchecked: a local FLS's
        offer is this process's own work, made from labels it checked when it
        heard them. Each is checked in the phase it says it is of; once the
        round's ROUND has come, an offer that says another phase is false. One
        whose phase is unknown (``fallback`` None) waits for a later look.
        """
        unchecked = [entry for entry in heard.kept if not entry.trusted]
        if not unchecked:
            return
        false: dict[int, str] = {}  # index into unchecked -> why
        by_phase: dict[int, list[int]] = {}
        for index, entry in enumerate(unchecked):
            if heard.phase is not None and entry.phase not in (None, heard.phase):
                false[index] = "an offer of another phase than its round's"
                continue
            phase = next((p for p in (entry.phase, heard.phase, fallback) if p is not None), None)
            if phase is not None:
                by_phase.setdefault(phase, []).append(index)
        for phase, indices in by_phase.items():
            offers = [(unchecked[index].sender, unchecked[index].offer) for index in indices]
            for found, why in self._implausible(offers, phase).items():
                false[indices[found]] = why
            for index in indices:
                unchecked[index].trusted = index not in false
        for index, why in sorted(false.items()):
            self.rejected.append((unchecked[index].sender, why))
        heard.discard([unchecked[index] for index in sorted(false)])

    def _implausible(self, entries: list[tuple[int, Offer]], phase: int) -> dict[int, str]:
        """{index into ``entries``: why} of the offers with a label or a reading that is false."""
        bad: dict[int, str] = {}
        if self._check_readings is not None:
            for index, (sender, offer) in enumerate(entries):
                if len(offer.reading_ids) and (why := self._check_readings(sender, offer)):
                    bad[index] = why
        if self._check is None:
            return bad
        heard = RoundOffers.of(entries)
        if not len(heard):
            return bad
        why_label = self._check(heard, phase)
        if not why_label.any():
            return bad
        # RoundOffers.of lays the offers out in a stable sort by sender.
        order = sorted(range(len(entries)), key=lambda index: entries[index][0])
        offer_of_label = np.repeat(order, [len(entries[index][1]) for index in order])
        for label in np.flatnonzero(why_label)[::-1]:
            bad.setdefault(int(offer_of_label[label]), REASONS[int(why_label[label])])
        return bad

    def on_offer(
        self, run_id: int, round_: int, sender: int, offer: Offer, phase: int | None = None
    ) -> Ack | None:
        """Hear ``sender``'s offer of round ``round_`` (of ``phase``, it says); the ack if heard.

        A sender counts once a round, by its offers kept; of a sender whose
        slots are full (:data:`OFFERS_PER_SENDER`), those found false first make
        room, and a further offer is ignored. An offer of a departed FLS is
        ignored. Offers of a run whose START has not come yet (another process
        was quicker) wait, at most :data:`EARLY_OFFERS` of them: what a forged
        run id can hold is bounded.
        """
        if not self._keep(run_id, round_, sender, offer, phase):
            return None
        return self._acknowledge(run_id, round_)

    def on_offers(self, run_id: int, round_: int, offers: Sequence[Broadcast]) -> Ack | None:
        """Hear ``offers`` of round ``round_`` at once (:meth:`on_offer` of each): a process's
        own FLSs' offers of a round. The ack if the round is then heard."""
        heard = self._heard.get((run_id, round_))
        if heard is None or round_ < self._first_round.get(run_id, round_ + 1):
            kept = [self._keep(run_id, round_, out.sender, out.offer, out.phase) for out in offers]
            return self._acknowledge(run_id, round_) if any(kept) else None
        # A round under way: its local offers kept in one pass, as _keep keeps each (the
        # fit's hundreds of rounds make a call per FLS most of a process's time).
        departed, local, senders = self.departed(run_id), self._local, heard.senders
        kept_any = False
        for out in offers:
            sender = out.sender
            if sender in departed:
                continue
            if sender not in local:
                kept_any |= self._keep(run_id, round_, sender, out.offer, out.phase)
            elif senders[sender] < OFFERS_PER_SENDER:
                heard.keep(_Kept(sender, out.offer, out.phase, trusted=True))
                kept_any = True
        return self._acknowledge(run_id, round_) if kept_any else None

    def on_block(self, block: FitBlock) -> Ack | None:
        """Hear the offers of ``block``, made together by local FLSs, as :meth:`on_offers`
        hears each of them. The ack if the round is then heard."""
        run_id, round_ = block.run_id, block.round
        heard = self._heard.get((run_id, round_))
        if heard is None or round_ < self._first_round.get(run_id, round_ + 1):
            return self.on_offers(run_id, round_, block.broadcasts())
        senders = block.senders.tolist()
        departed = self.departed(run_id)
        # A sender gone, or with an offer kept already (never, unless forged): kept as
        # :meth:`_keep` keeps each offer, and the block keeps the rest.
        odd = (departed.union(heard.senders) if departed else heard.senders.keys()) & set(senders)
        kept_any = False
        if odd:
            rows = np.isin(block.senders, np.fromiter(odd, dtype=np.int64, count=len(odd)))
            for row in np.flatnonzero(rows).tolist():
                out = block.broadcast(row)
                kept_any |= self._keep(run_id, round_, out.sender, out.offer, out.phase)
            block = block.rows(~rows)
        if len(block):
            heard.keep_block(block)
            kept_any = True
        return self._acknowledge(run_id, round_) if kept_any else None

    def _keep(
        self, run_id: int, round_: int, sender: int, offer: Offer, phase: int | None
    ) -> bool:
        """:meth:`on_offer` but for its ack: whether the offer was kept for the round."""
        if run_id not in self._first_round:
            self._early.append((run_id, round_, sender, offer, phase))
            return False
        if round_ < self._first_round[run_id] or sender in self.departed(run_id):
            return False  # from before a restart of the phase, or of an FLS gone
        heard = self._heard.get((run_id, round_))
        if heard is None:  # not setdefault: a record made per offer cost the race car 4 s
            heard = self._heard[(run_id, round_)] = _RoundHeard()
        local = sender in self._local
        if heard.senders[sender] >= OFFERS_PER_SENDER and not local:
            self._settle(heard)  # a forgery among them must not keep the real one out
        if heard.senders[sender] >= OFFERS_PER_SENDER:
            return False
        heard.keep(_Kept(sender, offer, phase, trusted=local))
        return True

    def _take_early(self, run_id: int) -> None:
        """Hear the offers of run ``run_id`` that came before its START."""
        early = [entry for entry in self._early if entry[0] == run_id]
        if early:
            self._early = deque(
                (entry for entry in self._early if entry[0] != run_id), self._early.maxlen
            )
            for entry in early:
                self.on_offer(*entry)

    def _acknowledge(self, run_id: int, round_: int) -> Ack | None:
        """The ack of round ``round_``, once an offer of every sender it expects may be true."""
        clocked = self._rounds.get((run_id, round_))
        heard = self._heard.get((run_id, round_))
        if clocked is None or heard is None or heard.counted < clocked[1]:
            return None
        # Complete by its count: the offers not checked yet must hold, or it is not.
        self._settle(heard)
        if heard.counted < clocked[1]:
            return None
        control = clocked[0]
        del self._rounds[(run_id, round_)]
        delivery = self._deliver(run_id, round_)
        return Ack(
            run_id,
            control.phase,
            round_,
            heard.counted,
            delivery.repairs,
            delivery.lost,
            delivery.latency,
        )

    def _radio_pairs(self) -> tuple[IntArray, IntArray]:
        """(sender, receiver) of every delivery to a local FLS that takes the sender's offers."""
        assert self._neighbours is not None
        senders, receivers = [], []
        for receiver in self._local:
            heard_from = np.asarray(self._neighbours(receiver), dtype=np.int64)
            senders.append(heard_from)
            receivers.append(np.full(heard_from.size, receiver, dtype=np.int64))
        if not senders:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        return np.concatenate(senders), np.concatenate(receivers)

    def _deliver(self, run_id: int, round_: int) -> Delivery:
        """What the lossy or slow radio made of round ``round_``'s offers to this process."""
        if self._loss is None or run_id not in self._pairs:
            return Delivery()
        senders, receivers = self._pairs[run_id]
        heard = self._heard.get((run_id, round_))
        sent = np.fromiter(heard.senders if heard is not None else (), dtype=np.int64)
        departed = np.fromiter(self.departed(run_id), dtype=np.int64)
        mine = np.isin(senders, sent) & ~np.isin(receivers, departed)
        return self._loss.deliver(run_id, round_, senders[mine], receivers[mine])

    def _forget(self, run_id: int, rounds: bool) -> None:
        """Drop what was heard in run ``run_id`` (and its rounds' controls if ``rounds``)."""
        self._heard = {key: heard for key, heard in self._heard.items() if key[0] != run_id}
        self._sent = {key: o for key, o in self._sent.items() if key[0] != run_id}
        self._fit_sent = {key: o for key, o in self._fit_sent.items() if key[0] != run_id}
        self._blocks_sent = {key: o for key, o in self._blocks_sent.items() if key[0] != run_id}
        self._beyond_sent = {k: o for k, o in self._beyond_sent.items() if k[0] != run_id}
        self._searching_sent = {k: o for k, o in self._searching_sent.items() if k[0] != run_id}
        if rounds:
            self._rounds = {key: c for key, c in self._rounds.items() if key[0] != run_id}
