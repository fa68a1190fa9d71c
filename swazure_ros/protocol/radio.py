"""The radio medium of one process, and its acknowledgement of each round (docs/protocol.md).

A radio broadcast reaches the FLSs within radio range of the sender (blind
or sweet range, line of sight ignored; spec section 4). A process that hosts
some of the swarm's FLSs hears every broadcast once and hands it to its own
FLSs in range (:meth:`RadioHub.on_offer`); it hands the coordinator's
controls to every local FLS that has not departed (:meth:`RadioHub.on_control`);
and once it has delivered every offer of a round it acknowledges the round
(:class:`Ack`), so that the coordinator can open the next one.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from .discovery import END, ROUND, START, Control

_Value = TypeVar("_Value")


@dataclass(frozen=True)
class Ack:
    """A process delivered every offer of one round (a RoundAck message)."""

    run_id: int
    phase: int
    round: int
    heard: int  # offers of the round delivered


class RadioHub:
    """Which local FLSs hear what, and when a round is delivered.

    ``local`` holds the ids of the FLSs this process hosts (it may shrink as
    FLSs stop); ``in_range(fls_id)`` gives the ids within radio range of one.
    """

    def __init__(
        self, local: Collection[int], in_range: Callable[[int], NDArray[np.int64]]
    ) -> None:
        self._local = local
        self._in_range = in_range
        self._departed: dict[int, frozenset[int]] = {}
        self._first_round: dict[int, int] = {}
        self._rounds: dict[tuple[int, int], Control] = {}  # (run, round) -> its ROUND
        self._heard: dict[tuple[int, int], int] = {}

    def departed(self, run_id: int) -> frozenset[int]:
        """The FLSs declared gone in run ``run_id``'s current phase."""
        return self._departed.get(run_id, frozenset())

    def on_control(self, control: Control) -> tuple[list[int], Ack | None]:
        """(the local FLSs to hand ``control`` to, the round's ack if it is now delivered)."""
        run = control.run_id
        if control.command == START:
            self._departed[run] = frozenset(control.departed_ids)
            self._first_round[run] = control.round
            self._drop(self._heard, run)
        departed = self.departed(run)
        recipients = [fls_id for fls_id in self._local if fls_id not in departed]
        ack = None
        if control.command == ROUND:
            self._rounds[(run, control.round)] = control
            ack = self._acknowledge(run, control.round)
        elif control.command == END:
            self._departed.pop(run, None)
            self._first_round.pop(run, None)
            self._drop(self._rounds, run)
            self._drop(self._heard, run)
        return recipients, ack

    def on_offer(self, run_id: int, round_: int, sender: int) -> tuple[list[int], Ack | None]:
        """(the local FLSs that hear ``sender``'s offer, the round's ack if now delivered)."""
        if round_ < self._first_round.get(run_id, 0):
            return [], None  # from before a restart of the phase
        departed = self.departed(run_id)
        recipients: list[int] = []
        if sender not in departed:
            recipients = [
                fls_id
                for fls_id in self._in_range(sender).tolist()
                if fls_id in self._local and fls_id not in departed
            ]
        key = (run_id, round_)
        self._heard[key] = self._heard.get(key, 0) + 1
        return recipients, self._acknowledge(run_id, round_)

    def _acknowledge(self, run_id: int, round_: int) -> Ack | None:
        control = self._rounds.get((run_id, round_))
        heard = self._heard.get((run_id, round_), 0)
        if control is None or heard < control.expected:
            return None
        del self._rounds[(run_id, round_)]
        return Ack(run_id, control.phase, round_, heard)

    @staticmethod
    def _drop(table: dict[tuple[int, int], _Value], run_id: int) -> None:
        for key in [key for key in table if key[0] == run_id]:
            del table[key]
