"""What a run of the swarm gives back: a discovery's estimates or a heuristic's moves,
and what each took (time, rounds, messages and bytes per topic)."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from ..core.evaluate import Evaluation
from ..core.heuristics.result import HeuristicResult
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


@dataclass
class DiscoveryResult:
    """One discovery run: every source's estimates and what it took."""

    run_id: int
    policy: str
    estimates: dict[int, Sequence[Estimate]]  # source id -> estimates
    departed: frozenset[int]
    rounds: int
    restarts: int
    seconds: float
    traffic: Traffic
    repairs: int = 0  # a lossy radio's repair requests and resends
    incomplete: bool = False  # deliveries kept being lost: no estimates, not wrong ones


@dataclass
class MoveResult:
    """A heuristic made by the swarm: the evaluation after it and what it took."""

    run_id: int
    evaluation: Evaluation  # the plain run with the resolved pairs made SWEET
    heuristic: HeuristicResult  # the engine's plan, resolved where the walk arrived
    batches: int
    moved: int  # move commands sent, returns included
    walks: int
    seconds: float
    traffic: Traffic
    timeouts: int = 0  # waits that ended at their deadline (each cost round_timeout s)


def discovery_result(
    run_id: int, policy: str, outcome: Outcome, seconds: float, traffic: Traffic
) -> DiscoveryResult:
    """The result of a round clock's run ``run_id`` that ended in ``outcome``."""
    return DiscoveryResult(
        run_id,
        policy,
        outcome.estimates,
        outcome.departed,
        outcome.rounds,
        outcome.restarts,
        seconds,
        traffic,
        outcome.repairs,
        outcome.incomplete,
    )


#: What one label costs an FLS in a discovery run, bytes: its costs, vector, path
#: link, sent and closed flags and the relaxation's scratch (protocol.discovery.search).
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
    first, last = results[0], results[-1]
    estimates: dict[int, Sequence[Estimate]] = {}
    traffic = Traffic()
    for result in results:
        estimates.update(result.estimates)
        traffic = traffic.plus(result.traffic)
    return DiscoveryResult(
        first.run_id,
        first.policy,
        estimates,  # an incomplete block's are none; the others' stand
        last.departed,
        sum(r.rounds for r in results),
        sum(r.restarts for r in results),
        sum(r.seconds for r in results),
        traffic,
        sum(r.repairs for r in results),
        any(r.incomplete for r in results),
    )


def move_result(run_id: int, moved: MoveOutcome, seconds: float, traffic: Traffic) -> MoveResult:
    """The result of a move run ``run_id`` that ended in ``moved``."""
    return MoveResult(
        run_id,
        moved.evaluation,
        moved.heuristic,
        moved.batches,
        moved.moved,
        moved.walks,
        seconds,
        traffic,
        moved.timeouts,
    )
