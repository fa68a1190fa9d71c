"""What a run of the swarm gives back: a discovery's estimates or a heuristic's moves,
and what each took (time, rounds, messages and bytes per topic)."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from ..core.traffic import TopicCounts
from .discovery.estimate import Estimate
from .moves import MoveOutcome
from .rounds import Outcome


@dataclass
class Traffic(TopicCounts):
    """Messages and bytes sent during discovery, per topic."""

    messages: dict[str, int] = field(default_factory=dict)
    bytes: dict[str, int] = field(default_factory=dict)

    def count(self, topic: str, size: int, messages: int = 1) -> None:
        """Count ``messages`` messages of ``size`` bytes in all on ``topic``."""
        self.messages[topic] = self.messages.get(topic, 0) + messages
        self.bytes[topic] = self.bytes.get(topic, 0) + size

    def since(self, earlier: Traffic) -> Traffic:
        """What was counted after ``earlier`` (a copy taken then)."""
        return Traffic(
            {k: v - earlier.messages.get(k, 0) for k, v in self.messages.items()},
            {k: v - earlier.bytes.get(k, 0) for k, v in self.bytes.items()},
        )

    def copy(self) -> Traffic:
        """A snapshot."""
        return Traffic(dict(self.messages), dict(self.bytes))

    def plus(self, other: Traffic) -> Traffic:
        """What both counted."""
        total = self.copy()
        for topic, messages in other.messages.items():
            total.count(topic, other.bytes.get(topic, 0), messages)
        return total


@dataclass(frozen=True)
class DiscoveryResult:
    """One discovery run: how its round clock ended (every source's estimates, rounds,
    restarts, departures), and what it took."""

    run_id: int
    policy: str
    outcome: Outcome
    seconds: float
    traffic: Traffic


@dataclass(frozen=True)
class MoveResult:
    """A heuristic made by the swarm: how its move run ended (the evaluation after it,
    batches, commands), and what it took."""

    run_id: int
    outcome: MoveOutcome
    seconds: float
    traffic: Traffic


#: What one label costs an FLS in a discovery run, bytes: its costs, vector, path
#: link, sent flag and hash key (protocol.discovery.labels). A run's blocks are sized
#: as if every FLS held every source's label: at the paper's density a search reaches
#: the FLSs within about the sensor's reach, two thirds of torus:10000.
LABEL_BYTES = 100
#: The labels that a whole-swarm discovery keeps at once, all processes together,
#: bytes: a swarm whose every FLS would hold every source's label runs its
#: sources in blocks (:func:`source_blocks`).
LABEL_MEMORY = 2 * 1024**3


def sources_per_run(fls_count: int, label_memory: int = LABEL_MEMORY) -> int:
    """How many sources one discovery run may search for, so that its labels fit."""
    return max(1, label_memory // (max(fls_count, 1) * LABEL_BYTES))


def source_blocks(fls_ids: Iterable[int], per_run: int) -> list[tuple[int, ...]]:
    """``fls_ids`` in blocks of at most ``per_run`` consecutive ids, as even as they go.

    Each block is one run's sources: every FLS keeps labels for the ids the
    block spans (``protocol.discovery.participant.source_range``), and every
    source's search is its own, so the blocks' results are the one run's.
    """
    ids = sorted(set(fls_ids))
    if per_run < 1:
        raise ValueError(f"sources per run must be at least 1, got {per_run}")
    count = -(-len(ids) // per_run) if ids else 1
    bounds = [len(ids) * k // count for k in range(count + 1)]
    return [tuple(ids[a:b]) for a, b in itertools.pairwise(bounds)]


def merged(results: Sequence[DiscoveryResult]) -> DiscoveryResult:
    """The runs of one discovery's source blocks as one run (the first's id)."""
    first = results[0]
    outcomes = [result.outcome for result in results]
    estimates: dict[int, Sequence[Estimate]] = {}
    traffic = Traffic()
    for result in results:
        estimates.update(result.outcome.estimates)
        traffic = traffic.plus(result.traffic)
    outcome = Outcome(
        estimates,  # an incomplete block's are none; the others' stand
        outcomes[-1].departed,
        sum(one.rounds for one in outcomes),
        sum(one.restarts for one in outcomes),
        tuple(itertools.chain.from_iterable(one.warnings for one in outcomes)),
        sum(one.repairs for one in outcomes),
        any(one.incomplete for one in outcomes),
        tuple(itertools.chain.from_iterable(one.fit_iterations for one in outcomes)),
    )
    seconds = sum(result.seconds for result in results)
    return DiscoveryResult(first.run_id, first.policy, outcome, seconds, traffic)
