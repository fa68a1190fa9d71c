"""What a run of the swarm gives back: a discovery's estimates or a heuristic's moves,
and what each took (time, rounds, messages and bytes per topic)."""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from ..core.traffic import TopicCounts
from .discovery.estimate import Estimate
from .discovery.places import place_bytes
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
    runs: int = 1  # the runs of its source blocks (merged), one after the other


@dataclass(frozen=True)
class MoveResult:
    """A heuristic made by the swarm: how its move run ended (the evaluation after it,
    batches, commands), and what it took."""

    run_id: int
    outcome: MoveOutcome
    seconds: float
    traffic: Traffic


#: The labels that a whole-swarm discovery keeps at once, all processes together,
#: bytes: a swarm whose every FLS would hold every source's label runs its
#: sources in blocks (:func:`source_blocks`). 1 GiB of places: a run's largest round
#: also holds that round's offers and the last round's, kept for the labels not yet
#: sent, about three times its tables' bytes more (BENCHMARKS.md, "A label's vector
#: summed when it is sent").
LABEL_MEMORY = 1024**3
#: The labels each share of a swarm over three or more processes or hosts keeps at once,
#: bytes (:func:`swarm_label_memory`): what each of two shares keeps of LABEL_MEMORY.
#: torus:30000 over four so took 18 blocks, not 35, and a third less time, its shares
#: at 2.4-2.6 GB, not 1.8-1.9, and its launcher at 3.95 GB, 3.90 before, in its comparison
#: with the engine (BENCHMARKS.md, "Where a block's label memory goes").
SHARE_LABEL_MEMORY = 512 * 1024**2


def swarm_label_memory(shares: int) -> int:
    """The labels a whole-swarm discovery over ``shares`` processes or hosts keeps at once, all
    together, bytes: :data:`LABEL_MEMORY`, or :data:`SHARE_LABEL_MEMORY` a share where
    that is more.

    Each share holds the label rows of its own FLSs only, so a swarm spread over
    more shares may hold more labels at once, in larger blocks of fewer rounds,
    each share no more than one of two does.
    """
    return max(LABEL_MEMORY, shares * SHARE_LABEL_MEMORY)


def sources_per_run(fls_count: int, label_memory: int = LABEL_MEMORY, fits: bool = False) -> int:
    """How many sources one discovery run may search for, so that its labels fit
    even if every FLS held every source's label: the first block's size.

    Such rows are a slot per source (``places.place_bytes``: 41 bytes a label, 137
    where labels ``fits``, as a fitting run's do); the runs after the first are sized
    by the memory the labels of the one before took (:func:`next_block_size`).
    """
    return max(1, label_memory // (max(fls_count, 1) * place_bytes(direct=True, fits=fits)))


def next_block_size(sources: int, label_bytes: int, label_memory: int = LABEL_MEMORY) -> int:
    """How many sources the next run may search for, after a run of ``sources`` whose labels
    took ``label_bytes`` at most (``Outcome.label_bytes``), so that its labels fit.

    A search leaves labels at the FLSs it reaches, not at every FLS: at display
    scale a block sized as if it did (:func:`sources_per_run`) fills a small part
    of the memory. Taking the next block's searches to reach as far as the last
    block's did, a block k times as large gives each FLS at most k times the
    labels, and a row at most 2k times as wide (a hash at most half full,
    rounded up to a power of two): the next block is as large as keeps twice
    ``label_bytes`` times k within ``label_memory``, and never smaller than the
    last.
    """
    if label_bytes <= 0:
        return sources
    return max(sources, sources * label_memory // (2 * label_bytes))


def source_blocks(fls_ids: Iterable[int], per_run: int) -> list[tuple[int, ...]]:
    """``fls_ids`` in blocks of at most ``per_run``, as even as they go: of C blocks, block k
    holds every C-th id from the k-th, ascending.

    Each block is one run's sources, and every source's search is its own, so
    the blocks' results are the one run's. Spread, not consecutive: ids are
    often laid out in space (a torus ring by ring, a cloud in scan order), and
    a block of neighbouring ids would leave many labels at the FLSs near them
    and none elsewhere, while a process's label table gives every FLS a row as
    wide as its fullest (``protocol.discovery.labels.LabelTable``).
    """
    ids = sorted(set(fls_ids))
    if per_run < 1:
        raise ValueError(f"sources per run must be at least 1, got {per_run}")
    count = -(-len(ids) // per_run) if ids else 1
    return [tuple(ids[first::count]) for first in range(count)]


def next_block(fls_ids: Sequence[int], per_run: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """(the first of ``fls_ids``' :func:`source_blocks` of ``per_run``, the ids left), both
    ascending: for runs whose sizes follow what the runs before took."""
    block = source_blocks(fls_ids, per_run)[0]
    taken = set(block)
    return block, tuple(fls for fls in sorted(set(fls_ids)) if fls not in taken)


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
        max(one.label_bytes for one in outcomes),  # one run after the other
    )
    seconds = sum(result.seconds for result in results)
    runs = sum(result.runs for result in results)
    return DiscoveryResult(first.run_id, first.policy, outcome, seconds, traffic, runs)
