"""The radio of one process: what its FLSs hear of a round, and its acknowledgement.

A radio broadcast reaches the FLSs within radio range of the sender (blind
or sweet range, line of sight ignored; spec section 4). A process that hosts
some of the swarm's FLSs hears every broadcast once (:meth:`RadioHub.on_offer`)
and keeps the round's offers; at the coordinator's next control it hands
them, in one :class:`~.discovery.RoundOffers`, to every local FLS that has
not departed (:meth:`RadioHub.on_control`). Each FLS takes from it only the
labels of its own neighbours, every one of them within its radio range, so
it hears exactly what a real radio would bring it. Once the process has
every offer of a round, it acknowledges the round (:class:`Ack`), so that
the coordinator can open the next one.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass

from .discovery import END, ROUND, START, Control, Offer, RoundOffers


@dataclass(frozen=True)
class Ack:
    """A process heard every offer of one round (a RoundAck message)."""

    run_id: int
    phase: int
    round: int
    heard: int  # offers of the round heard


class RadioHub:
    """A round's offers, the local FLSs that take them, and when a round is heard.

    ``local`` holds the ids of the FLSs this process hosts (it may shrink as
    FLSs stop).
    """

    def __init__(self, local: Collection[int]) -> None:
        self._local = local
        self._departed: dict[int, frozenset[int]] = {}
        self._first_round: dict[int, int] = {}
        self._rounds: dict[tuple[int, int], Control] = {}  # (run, round) -> its ROUND
        self._heard: dict[tuple[int, int], int] = {}
        self._offers: dict[tuple[int, int], list[tuple[int, Offer]]] = {}

    def abandon(self) -> None:
        """Forget every run (their coordinator is gone)."""
        self._departed.clear()
        self._first_round.clear()
        self._rounds.clear()
        self._heard.clear()
        self._offers.clear()

    def departed(self, run_id: int) -> frozenset[int]:
        """The FLSs declared gone in run ``run_id``'s current phase."""
        return self._departed.get(run_id, frozenset())

    def on_control(self, control: Control) -> tuple[list[int], Ack | None, RoundOffers | None]:
        """(the local FLSs to hand ``control`` to, the round's ack if now heard, the offers).

        The offers are those of the rounds before ``control.round``, for a
        ROUND or the END; a START drops those of the phase before.
        """
        run = control.run_id
        heard = None
        if control.command == START:
            self._departed[run] = frozenset(control.departed_ids)
            self._first_round[run] = control.round
            self._forget(run, rounds=False)
        else:
            done = sorted(key for key in self._offers if key[0] == run and key[1] < control.round)
            heard = RoundOffers.of([entry for key in done for entry in self._offers.pop(key)])
        departed = self.departed(run)
        recipients = [fls_id for fls_id in self._local if fls_id not in departed]
        ack = None
        if control.command == ROUND:
            self._rounds[(run, control.round)] = control
            ack = self._acknowledge(run, control.round)
        elif control.command == END:
            self._departed.pop(run, None)
            self._first_round.pop(run, None)
            self._forget(run, rounds=True)
        return recipients, ack, heard

    def on_offer(self, run_id: int, round_: int, sender: int, offer: Offer) -> Ack | None:
        """Hear ``sender``'s offer of round ``round_``; the round's ack if now heard."""
        if round_ < self._first_round.get(run_id, 0):
            return None  # from before a restart of the phase
        key = (run_id, round_)
        if sender not in self.departed(run_id):
            self._offers.setdefault(key, []).append((sender, offer))
        self._heard[key] = self._heard.get(key, 0) + 1
        return self._acknowledge(run_id, round_)

    def _acknowledge(self, run_id: int, round_: int) -> Ack | None:
        control = self._rounds.get((run_id, round_))
        heard = self._heard.get((run_id, round_), 0)
        if control is None or heard < control.expected:
            return None
        del self._rounds[(run_id, round_)]
        return Ack(run_id, control.phase, round_, heard)

    def _forget(self, run_id: int, rounds: bool) -> None:
        """Drop what was heard in run ``run_id`` (and its rounds' controls if ``rounds``)."""
        self._heard = {key: n for key, n in self._heard.items() if key[0] != run_id}
        self._offers = {key: o for key, o in self._offers.items() if key[0] != run_id}
        if rounds:
            self._rounds = {key: c for key, c in self._rounds.items() if key[0] != run_id}
