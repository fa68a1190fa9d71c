"""What a heuristic returns: per pair, whether it was tried and resolved, its new path and
estimate, and every individual move (:class:`HeuristicResult`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ...core.arrays import FloatArray, IntArray
from ..evaluation import REASON_BLOCKED, SWEET_PATH, PairResults
from ..neighbourhood import Neighbourhood
from ..path_arrays import Paths
from .compat import TEXT, Compat

PLAIN = "plain"


MOVE_OBSTRUCTING = "move-obstructing"


MOVE_SOURCE = "move-source"


TECHNIQUES = (PLAIN, MOVE_OBSTRUCTING, MOVE_SOURCE)


#: Move Source's threshold T, at most: 26 probes a step, and the published study's
#: largest T is 10; beyond this the source would fly a thousand radii from its point.
MAX_THRESHOLD = 1000


class PlainPairs(Protocol):
    """What a heuristic reads of a plain run: its neighbourhood, policy and pairs.

    An :class:`~..evaluation.Evaluation` (every pair), or a :class:`PairBlock`
    (a block of them, :mod:`.regions`): a pair's outcome depends on nothing
    but the swarm's original shape and its own plain result (docs/core.md,
    "Move Obstructing and Move Source in blocks").
    """

    @property
    def hood(self) -> Neighbourhood: ...

    @property
    def policy(self) -> str: ...

    @property
    def pairs(self) -> PairResults: ...


@dataclass(frozen=True)
class PairBlock:
    """A block of a plain run's pairs, with the run's neighbourhood and policy."""

    hood: Neighbourhood
    policy: str
    pairs: PairResults


@dataclass(frozen=True)
class MovedPairs(PairResults):
    """A block of a run's pairs after a heuristic, with the heuristic's record of them (tried,
    resolved, moves): what a run made block by block gives ``take`` (:mod:`.regions`)."""

    heuristic: HeuristicResult | None = None

    @classmethod
    def of(cls, pairs: PairResults, heuristic: HeuristicResult) -> MovedPairs:
        """``pairs`` (after the heuristic) with its record ``heuristic``."""
        values = {name: getattr(pairs, name) for name in PairResults.__dataclass_fields__}
        return cls(**values, heuristic=heuristic)


@dataclass(frozen=True)
class HeuristicResult:
    """Outcome of a heuristic for M ordered blind pairs; moves as a CSR over pairs."""

    technique: str
    threshold: int | None
    tried: NDArray[np.bool_]  # (M,)
    resolved: NDArray[np.bool_]  # (M,)
    paths: Paths  # the resolved pairs' sweet paths (not found elsewhere)
    estimate: FloatArray  # (M, 3), cm; nan where not resolved
    truth: FloatArray  # (M, 3), cm: p_j - p_i, or p_j - q for Move Source
    move_offsets: IntArray  # (M + 1,)
    move_fls: IntArray  # (K,), swarm index of the FLS that moved
    move_from: FloatArray  # (K, 3), cm
    move_to: FloatArray  # (K, 3), cm
    flown: FloatArray = field(default_factory=lambda: np.zeros(0))  # (M,), Move Source
    compat: Compat = TEXT
    source_body: bool = False  # Move Source: the source's body at q checked (--source-body)

    def moves(self, pair: int) -> list[tuple[int, FloatArray, FloatArray]]:
        """The moves made for pair ``pair``, in order.

        Parameters
        ----------
        pair : int
            An index into the evaluation's pairs.

        Returns
        -------
        list of (int, (3,) array, (3,) array)
            The FLS that moved (a swarm index), from where and to where, cm.
        """
        span = range(self.move_offsets[pair], self.move_offsets[pair + 1])
        return [(int(self.move_fls[k]), self.move_from[k], self.move_to[k]) for k in span]

    @property
    def move_distance(self) -> FloatArray:
        """Length of every individual move, cm: (K,)."""
        return np.asarray(np.linalg.norm(self.move_to - self.move_from, axis=1))


def check_technique(technique: str) -> str:
    """Return ``technique`` if valid, else raise ValueError listing the valid ones.

    Parameters
    ----------
    technique : str

    Returns
    -------
    str
        ``technique``, one of :data:`TECHNIQUES`.

    Raises
    ------
    ValueError
        Any other name.

    Examples
    --------
    >>> from swazure_ros.core.heuristics.result import check_technique
    >>> check_technique("move-sauce")
    Traceback (most recent call last):
    ...
    ValueError: unknown technique 'move-sauce'; expected one of plain, move-obstructing, ...
    """
    if technique not in TECHNIQUES:
        raise ValueError(
            f"unknown technique {technique!r}; expected one of {', '.join(TECHNIQUES)}"
        )
    return technique


def blocked_pairs(evaluation: PlainPairs) -> IntArray:
    """The pairs a heuristic tries: BLOCKED (``S_all`` joins them) and with no sweet path.

    Parameters
    ----------
    evaluation : PlainPairs
        A plain run, or a block of its pairs.

    Returns
    -------
    (B,) array of int
        Indices into ``evaluation.pairs``, increasing.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.clouds import cube_lattice
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> jitter = np.random.default_rng(0).normal(0.0, 0.1, (64, 3))
    >>> swarm = make_swarm(cube_lattice(64) * 2.6 + jitter, radius=1.0)  # a 4x4x4 block, cm
    >>> plain = evaluate(swarm, published, "shortest-length")
    >>> from swazure_ros.core.heuristics.result import blocked_pairs
    >>> len(blocked_pairs(plain))
    600
    """
    pairs = evaluation.pairs
    return np.flatnonzero((pairs.reason == REASON_BLOCKED) & (pairs.status != SWEET_PATH))


@dataclass(frozen=True)
class PairFindings:
    """A heuristic's findings per pair before its moves: which it tried and resolved,
    (M,) each, and the estimate and truth of each resolved one, (M, 3), cm (nan elsewhere)."""

    tried: NDArray[np.bool_]
    resolved: NDArray[np.bool_]
    estimate: FloatArray
    truth: FloatArray

    @classmethod
    def nothing_yet(cls, size: int) -> PairFindings:
        """Findings for ``size`` pairs, none tried: filled in place as the heuristic runs."""
        unknown = np.full((size, 3), np.nan)
        return cls(np.zeros(size, bool), np.zeros(size, bool), unknown, unknown.copy())
