"""What a run of the swarm gives back: a discovery's estimates or a heuristic's moves,
and what each took (time, rounds, messages and bytes per topic)."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.evaluate import Evaluation
from ..core.heuristics.result import HeuristicResult
from .discovery.estimate import Estimate
from .moves import MoveOutcome
from .rounds import Outcome


@dataclass
class Traffic:
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

    @property
    def total_messages(self) -> int:
        """Messages on every topic."""
        return sum(self.messages.values())

    @property
    def total_bytes(self) -> int:
        """Bytes on every topic (serialised payloads)."""
        return sum(self.bytes.values())


@dataclass
class DiscoveryResult:
    """One discovery run: every source's estimates and what it took."""

    run_id: int
    policy: str
    estimates: dict[int, list[Estimate]]  # source id -> estimates
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
