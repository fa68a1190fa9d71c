"""A heuristic made by the swarm, as a state machine: move, walk the paths, return.

After a whole-swarm discovery run, :class:`MoveRun` applies Move Obstructing
or Move Source to every BLOCKED pair: the core engine plans the moves from
the original shape (which obstructers step aside and where, or where a
source probes), and the run makes them batch by batch
(:func:`~.schedule.move_batches`). For each batch it asks
for the batch's moves in one world revision, sends a path walk to the source
of every pair of the batch once that revision is seen (the FLSs of the path
measure their hops again and sum them: :func:`step_walk`), waits for the
walks' results, and returns the moved FLSs to their points.

Every wait has a deadline of ``timeout`` seconds without progress; a wait
that times out is logged and the run goes on, so a lost walk costs its pair
(it stays unresolved) and never the run.
"""

from __future__ import annotations

from collections.abc import Container, Sequence
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..core.arrays import FloatArray, IntArray
from ..core.evaluation import NO_PATH, REASON_BLOCKED, SWEET_PATH, Evaluation
from ..core.heuristics.folding import apply
from ..core.heuristics.obstructing import move_obstructing
from ..core.heuristics.result import MOVE_OBSTRUCTING, MOVE_SOURCE, HeuristicResult
from ..core.heuristics.source import move_source
from ..core.sensor import SWEET
from .discovery.estimate import Estimate
from .schedule import move_batches, walked

# Kinds of move; the values equal MoveCommand's KIND_*.
STEP_ASIDE, PROBE, RETURN = 0, 1, 2
# States of a path walk; the values equal PathWalk's STATE_*.
WALKING, ARRIVED, FAILED = 0, 1, 2

_MOVING, _WALKING, _RETURNING = "moving", "walking", "returning"


def commanded_points(
    home: FloatArray, kinds: NDArray[np.int64], displacement: FloatArray
) -> FloatArray:
    """(K, 3) cm where commanded FLSs go: home (K, 3) + displacement, or home for a return."""
    aside = kinds != RETURN
    return np.asarray(home + np.where(aside[:, None], displacement, 0.0), dtype=np.float64)


@dataclass(frozen=True)
class Move:
    """One FLS's move, made together with the ``group_size`` moves of group ``group``."""

    fls_id: int
    kind: int  # STEP_ASIDE, PROBE or RETURN
    source_id: int  # the blind pair the move serves
    target_id: int
    group: int  # the world revision the group's moves make
    group_size: int
    displacement: FloatArray | None  # (3,) from the FLS's point, cm; None to return


@dataclass(frozen=True)
class Walk:
    """A path walk: it travels FLS to FLS along ``path``, summing the measured hop vectors."""

    run_id: int
    revision: int  # measure in this world revision or a later one
    path: tuple[int, ...]  # FLS ids, source first, target last
    hop: int = 0  # the walk is at path[hop]
    state: int = WALKING
    vector: FloatArray = field(default_factory=lambda: np.zeros(3))  # summed so far, cm

    @property
    def source_id(self) -> int:
        """The pair's source FLS."""
        return self.path[0]

    @property
    def target_id(self) -> int:
        """The pair's target FLS."""
        return self.path[-1]

    @property
    def at(self) -> int:
        """The FLS the walk is addressed to now."""
        return self.path[self.hop]


class Camera(Protocol):
    """What an FLS's camera measures now: ids (K,), range classes (K,), vectors (K, 3) cm."""

    @property
    def target_ids(self) -> IntArray: ...

    @property
    def range_class(self) -> NDArray[np.int8]: ...

    @property
    def vector(self) -> FloatArray: ...


def next_hop(walk: Walk) -> tuple[int, ...]:
    """The FLS whose measurement the walk's FLS adds next (none at the target)."""
    return walk.path[walk.hop + 1 : walk.hop + 2]


def step_walk(walk: Walk, seen: Camera | None) -> Walk:
    """The walk after its FLS, ``walk.at``, took its turn with what its camera ``seen`` measures.

    On the way out each FLS adds its own measurement of the next hop
    (:func:`next_hop`; ``seen`` may hold that one alone), which must be sweet
    and in sight; the target turns the walk back to the source
    (blind neighbours are within radio range) and measures nothing: its
    ``seen`` may be None. Sums run from the source outwards, as the core
    engine sums.
    """
    if walk.hop + 1 >= len(walk.path):
        return replace(walk, state=ARRIVED, hop=0)
    if seen is None:
        raise ValueError(f"FLS {walk.at} must measure its next hop, {walk.path[walk.hop + 1]}")
    where = np.flatnonzero(seen.target_ids == walk.path[walk.hop + 1])
    if len(where) == 0 or seen.range_class[where[0]] != SWEET:
        return replace(walk, state=FAILED, hop=0)
    return replace(walk, hop=walk.hop + 1, vector=walk.vector + seen.vector[where[0]])


def hops_here(walk: Walk, here: Container[int]) -> tuple[list[int], list[int]]:
    """The hops ``walk`` makes on its way out before it leaves the FLSs ``here`` (a
    process's): the FLS of each, and the FLS it measures next (:func:`next_hop`), in order.

    What a process's FLSs will measure of the walk, read at once; none once it has
    turned back to its source.
    """
    fls_ids: list[int] = []
    next_ids: list[int] = []
    if walk.state != WALKING:
        return fls_ids, next_ids
    for hop in range(walk.hop, len(walk.path) - 1):
        if walk.path[hop] not in here:
            break
        fls_ids.append(walk.path[hop])
        next_ids.append(walk.path[hop + 1])
    return fls_ids, next_ids


def walk_estimate(walk: Walk) -> Estimate:
    """The source's estimate of a walk that came back: SWEET with its vector, or NO_PATH."""
    arrived = walk.state == ARRIVED
    return Estimate(
        walk.target_id,
        SWEET_PATH if arrived else NO_PATH,
        REASON_BLOCKED,
        walk.path if arrived else (),
        vector=np.array(walk.vector, dtype=np.float64) if arrived else np.full(3, np.nan),
        radio_path=walk.path,
    )


@dataclass(frozen=True)
class MoveOutcome:
    """A heuristic made by the swarm: the evaluation after it and what it took."""

    evaluation: Evaluation  # the plain run with the resolved pairs made SWEET
    heuristic: HeuristicResult  # the engine's plan, resolved where the walk arrived
    batches: int
    moved: int  # move commands sent, returns included
    walks: int
    warnings: tuple[str, ...] = ()
    timeouts: int = 0  # waits that ended at their deadline, not by what they waited for


class MoveRun:
    """Makes ``technique``'s moves for every BLOCKED pair of ``evaluation`` (the plain run).

    ``threshold`` bounds Move Source's probes (steps of r); ``source_body`` plans them
    with the source's own body at its probe point checked (``move_source``'s).
    ``revision`` is the newest world revision seen when the run starts.
    """

    def __init__(
        self,
        run_id: int,
        evaluation: Evaluation,
        technique: str,
        threshold: int,
        revision: int,
        timeout: float,
        source_body: bool = False,
    ) -> None:
        if technique == MOVE_OBSTRUCTING:
            self.plan, self.kind = move_obstructing(evaluation), STEP_ASIDE
        elif technique == MOVE_SOURCE:
            self.plan = move_source(evaluation, threshold, source_body=source_body)
            self.kind = PROBE
        else:
            raise ValueError(f"no moves to make for technique {technique!r}")
        self.run_id = run_id
        self.evaluation = evaluation
        self.batches = move_batches(evaluation, self.plan)
        self.timeout = timeout
        self.revision = revision  # the newest revision seen
        self.asked_revision = revision  # the revision our last group of moves makes
        self.moved = 0
        self.walks = 0
        self.warnings: list[str] = []
        self.outcome: MoveOutcome | None = None
        #: Waits that ended at their deadline (each cost ``timeout`` seconds).
        self.timeouts = 0
        self._ids = evaluation.hood.swarm.cloud_index
        self._home = evaluation.hood.swarm.points
        self._batch = -1
        self._stage = _RETURNING
        self._moves: dict[int, tuple[int, int, FloatArray]] = {}  # FLS id -> (source, target, to)
        self._walking: dict[tuple[int, int], int] = {}  # (source, target) -> pair
        self._walked: set[tuple[int, int]] = set()
        self._vectors: dict[int, FloatArray] = {}  # pair -> summed vector
        self._deadline = float("inf")

    @property
    def done(self) -> bool:
        """True once every batch is made (:attr:`outcome` holds the result)."""
        return self.outcome is not None

    @property
    def progress(self) -> str:
        """How far the run is, for a person watching."""
        return f"batch {max(self._batch + 1, 0):,} of {len(self.batches):,}"

    def start(self, now: float) -> list[Move | Walk]:
        """Begin: the first batch's moves (or the end, when nothing is to be moved)."""
        return self._next_batch(now)

    def on_revision(self, revision: int, now: float) -> list[Move | Walk]:
        """The world reached ``revision``."""
        self.revision = max(self.revision, revision)
        if self.done or self._stage == _WALKING or self.revision < self.asked_revision:
            return []
        return self._advance(now)

    def on_estimates(
        self, source: int, estimates: Sequence[Estimate], now: float
    ) -> list[Move | Walk]:
        """Source ``source`` reported walk results."""
        if self._stage != _WALKING or self.done:
            return []
        for one in estimates:
            key = (source, one.target)
            if key in self._walking and key not in self._walked:
                self._walked.add(key)
                if one.status == SWEET_PATH:
                    self._vectors[self._walking[key]] = one.vector
        self._deadline = now + self.timeout
        return self._advance(now) if len(self._walked) == len(self._walking) else []

    def on_tick(self, now: float) -> list[Move | Walk]:
        """The time is ``now``: end a wait whose deadline has passed."""
        if self.done or now <= self._deadline:
            return []
        self.timeouts += 1
        if self._stage == _WALKING:
            missing = sorted(set(self._walking) - self._walked)
            self.warnings.append(f"no result of the path walks {missing[:10]}")
        else:
            self.warnings.append(
                f"world revision {self.asked_revision} not seen: moves may be lost"
            )
        return self._advance(now)

    def _advance(self, now: float) -> list[Move | Walk]:
        if self._stage == _MOVING:
            return self._walk(now)
        if self._stage == _WALKING:
            self._stage = _RETURNING
            return self._move(RETURN, now)
        return self._next_batch(now)

    def _next_batch(self, now: float) -> list[Move | Walk]:
        self._batch += 1
        if self._batch >= len(self.batches):
            self._finish()
            return []
        ids, pairs = self._ids, self.evaluation.pairs
        self._moves = {}
        for pair in self.batches[self._batch].tolist():
            served = (int(ids[pairs.source[pair]]), int(ids[pairs.target[pair]]))
            for fls, _, to in self.plan.moves(pair):
                self._moves[int(ids[fls])] = (*served, to)
        self._stage = _MOVING
        return self._move(self.kind, now)

    def _move(self, kind: int, now: float) -> list[Move | Walk]:
        self.asked_revision = max(self.asked_revision, self.revision) + 1
        self.moved += len(self._moves)
        self._deadline = now + self.timeout
        rows = np.searchsorted(self._ids, list(self._moves))
        return [
            Move(
                fls_id,
                kind,
                source,
                target,
                self.asked_revision,
                len(self._moves),
                None if kind == RETURN else to - self._home[row],
            )
            for (fls_id, (source, target, to)), row in zip(
                self._moves.items(), rows.tolist(), strict=True
            )
        ]

    def _walk(self, now: float) -> list[Move | Walk]:
        self._stage = _WALKING
        paths, ids = self.plan.paths, self._ids
        walks = []
        self._walking, self._walked = {}, set()
        for pair in self.batches[self._batch].tolist():
            path = paths.nodes[paths.offsets[pair] : paths.offsets[pair + 1]]
            walk = Walk(self.run_id, self.asked_revision, tuple(ids[path].tolist()))
            self._walking[(walk.source_id, walk.target_id)] = pair
            walks.append(walk)
        self.walks += len(walks)
        self._deadline = now + self.timeout
        return list(walks)

    def _finish(self) -> None:
        self._deadline = float("inf")
        heuristic = walked(self.plan, self._vectors)
        self.outcome = MoveOutcome(
            apply(self.evaluation, heuristic),
            heuristic,
            len(self.batches),
            self.moved,
            self.walks,
            tuple(self.warnings),
            self.timeouts,
        )
