"""Who takes part in a swarm's next run: the FLSs departed or gone, and the radios to hear.

The coordinator's record of the swarm's members (docs/protocol.md, "How a
search ends, also when an FLS is gone" and "Coming back"): an FLS departs
when a run goes on without it (silent past its round's deadline) and is gone
when its node left the graph too. A departed FLS comes back when the graph
shows it again, or when a radio it speaks through signs a message made after
it was known gone. A process's radio is named as its node; an FLS in a
process of its own is its own radio, so that its leaving and coming back
change how many radios (``hosts``) must acknowledge a round.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable


class Membership:
    """Who takes part in the next run: the FLSs departed or gone, and the radios to hear.

    ``departed``: FLSs the runs go on without; ``gone``: those of them whose
    nodes left the graph. An FLS in a process of its own is its own radio,
    named ``own_radio(fls_id)``; ``radio_fls(name)`` is the FLS a radio is,
    None for a radio of a process of several (the node names of
    ``ros.plumbing.names``: ``fls_7``, ``host_0``).
    """

    def __init__(
        self,
        hosts: int,
        own_radio: Callable[[int], str],
        radio_fls: Callable[[str], int | None],
    ) -> None:
        self.hosts = hosts
        self._own_radio = own_radio
        self._radio_fls = radio_fls
        self.departed: set[int] = set()
        self.gone: set[int] = set()
        self.radios: set[str] = set()  # node names of the processes' radios (acks' writers)
        self._radios_gone: set[str] = set()  # of departed FLSs that were their own radio
        # Who speaks through each radio (its acks' senders), and when each departed FLS
        # was known gone (wall-clock ns): a signed ack made later says it is back.
        self._voices: dict[str, set[int]] = {}
        self._departed_at: dict[int, int] = {}
        self._back_in_run: set[int] = set()

    def see_radios(self, names: Iterable[str]) -> None:
        """Radios ``names`` are there: the acks' writers on the graph, or radios whose signed
        heartbeats say they hear the controls.

        Counted in their order until every host's radio is known, and never
        the radio of an FLS gone: an FLS that dies leaves with its radio only
        if its radio was known (:meth:`lose`). One killed as its swarm came
        up, before the graph's look listed its radio, left its radio counted
        among the hosts, and every later round waited for its acknowledgement
        until the run ended incomplete (2026-12-04, under a full suite's load).
        """
        for name in names:
            if len(self.radios) >= self.hosts:
                return
            if self._radio_fls(name) not in self.gone:
                self.radios.add(name)

    def lose(self, newly: set[int]) -> int:
        """FLSs ``newly`` gone from the graph: departed. How many radios went with them."""
        self.gone |= newly
        self._note_departed(newly)
        self.departed |= newly
        radios = {self._own_radio(fls_id) for fls_id in newly} & self.radios
        self.radios -= radios
        self._radios_gone |= radios
        self.hosts -= len(radios)
        return len(radios)

    def settle(self, departed: Iterable[int]) -> None:
        """A discovery run's departed, at its end: the swarm's, but for those back meanwhile."""
        departed = set(departed)
        self._note_departed(departed - self.departed - self._back_in_run)
        self.departed = departed - self._back_in_run
        self._back_in_run.clear()

    def hear(self, host: str, senders: Iterable[int]) -> None:
        """FLSs ``senders`` spoke through radio ``host``."""
        self._voices.setdefault(host, set()).update(senders)

    def voices(self, host: str) -> set[int]:
        """The FLSs radio ``host`` speaks for: those heard through it, and the FLS it is."""
        own = self._radio_fls(host)
        return self._voices.get(host, set()) | ({own} if own is not None else set())

    def back_by(self, host: str, signed: int) -> set[int]:
        """Departed FLSs of radio ``host`` that a message it signed at ``signed`` (wall-clock
        ns) says are back: those known gone before it was signed, and not gone from the graph.
        """
        voices = self.voices(host)
        return {
            fls_id
            for fls_id in (voices & self.departed) - self.gone
            if self._departed_at.get(fls_id, signed) < signed
        }

    def take_back(self, back: set[int], in_run: bool) -> None:
        """FLSs departed and back: they take part again from the next run on.

        A run under way (``in_run``) keeps its departed (its rounds and labels
        were made without them); the next starts with them, and every pair of
        theirs is searched again.
        """
        self.gone -= back
        self.departed -= back
        if in_run:
            self._back_in_run |= back
        for fls_id in back:
            self._departed_at.pop(fls_id, None)
        radios = {self._own_radio(fls_id) for fls_id in back} & self._radios_gone
        self._radios_gone -= radios
        self.hosts += len(radios)

    def _note_departed(self, newly: set[int]) -> None:
        now = time.time_ns()
        self._departed_at.update(dict.fromkeys(newly, now))
