"""A lossy, slow radio: what becomes of each round's deliveries to a process.

The in-process radio (:mod:`.radio`) hears every offer at once; a
:class:`RadioLoss` decides, by seeded counter-based draws, which deliveries
were lost, repaired or late, the same in every process (:class:`Delivery`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.arrays import IntArray
from ..core.draws import uniforms


@dataclass(frozen=True)
class Delivery:
    """What the radio made of one round's deliveries to one process."""

    repairs: int = 0  # repair requests and resends sent
    lost: int = 0  # deliveries lost on every try
    latency: float = 0.0  # s from the round's start until its last delivery arrived


@dataclass(frozen=True)
class RadioLoss:
    """A lossy, slow radio: each message is lost with ``probability`` and late by up to ``delay``.

    Every FLS broadcasts in every round, so a receiver knows whom it did not
    hear: it asks that neighbour again (a repair request) and the neighbour
    sends its offer again, each of the two lost with the same probability,
    up to ``attempts`` tries in all. Each message takes a delay drawn
    uniformly from [0, ``delay``] s. A receiver takes a broadcast for lost
    once ``delay`` has passed, and a repair once twice that has passed since
    its request, so try k >= 1 starts at ``(2k - 1) delay`` and every
    delivery that arrives does so within ``(2 attempts - 1) delay``. The fate
    and delay of every message are counter-based draws of (seed, run, round,
    sender, receiver, try): seeded, and the same in any process. A delivery
    lost on every try is lost for good: the round's acknowledgement says so,
    and the coordinator restarts the phase.
    """

    probability: float = 0.0
    seed: int = 0
    attempts: int = 12
    delay: float = 0.0  # s, the longest one-way delay of a radio message

    def __post_init__(self) -> None:
        if not 0.0 <= self.probability < 1.0:
            raise ValueError(f"radio loss must be in [0, 1), got {self.probability}")
        if self.attempts < 1:
            raise ValueError(f"radio attempts must be at least 1, got {self.attempts}")
        if not 0.0 <= self.delay < float("inf"):
            raise ValueError(f"radio delay must be a number of seconds >= 0, got {self.delay}")

    @property
    def active(self) -> bool:
        """True when the radio loses or delays anything."""
        return self.probability > 0.0 or self.delay > 0.0

    def deliver(
        self, run_id: int, round_: int, senders: IntArray, receivers: IntArray
    ) -> Delivery:
        """What became of the deliveries sender -> receiver (M each) in round ``round_``."""
        if not self.active or senders.size == 0:
            return Delivery()
        keys = [np.full(senders.size, run_id), np.full(senders.size, round_), senders, receivers]
        # Columns 0 .. 2 attempts - 2: the broadcast, then per repair the request and the
        # resend; the next as many columns: each of those messages' delay.
        messages = 2 * self.attempts - 1
        draws = uniforms(self.seed, keys, 2 * messages)
        arrived = draws[:, :messages] >= self.probability
        late = self.delay * draws[:, messages:]
        delivered = arrived[:, 0].copy()
        arrival = np.where(delivered, late[:, 0], np.inf)
        repairs = 0
        for attempt in range(1, self.attempts):
            waiting = ~delivered
            if not waiting.any():
                break
            asked = waiting & arrived[:, 2 * attempt - 1]
            repairs += int(waiting.sum()) + int(asked.sum())  # requests, then resends
            now = asked & arrived[:, 2 * attempt]
            start = (2 * attempt - 1) * self.delay
            arrival[now] = start + late[now, 2 * attempt - 1] + late[now, 2 * attempt]
            delivered |= now
        latency = float(arrival[delivered].max()) if delivered.any() else 0.0
        return Delivery(repairs, int((~delivered).sum()), latency)
