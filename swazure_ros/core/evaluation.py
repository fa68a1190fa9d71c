"""What an evaluation gives: each blind pair's results (:class:`PairResults`) and the run.

A pair's ``status`` and ``reason`` are codes, whose values equal the
constants of swazure_interfaces/PoseEstimate and whose names are
:data:`STATUS_NAMES` and :data:`REASON_NAMES`; an :class:`Evaluation` holds
the neighbourhood, the policy, every ordered blind pair and the summary.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .arrays import FloatArray, IntArray
from .metrics import pose_errors
from .neighbourhood import Neighbourhood
from .summary import Summary

# Statuses and reasons; the values equal the constants of swazure_interfaces/PoseEstimate.
SWEET_PATH, DECAYING_PATH, NO_PATH = 0, 1, 2
#: A distributed run that ended before its result (never from the engine).
ABORTED = 3
STATUS_NAMES = ("SWEET", "DECAYING", "NO_PATH", "ABORTED")
REASON_NONE, REASON_BLOCKED, REASON_NO_SWEET_PATH = 0, 1, 2
#: Why a distributed run was ABORTED: its coordinator left the graph mid-run.
REASON_COORDINATOR_LOST = 3
REASON_NAMES = ("", "BLOCKED", "NO_SWEET_PATH", "COORDINATOR_LOST")


@dataclass(frozen=True)
class PairResults:
    """Per ordered blind pair (M of them): status, path and errors. Indices are swarm indices."""

    source: IntArray  # (M,)
    target: IntArray  # (M,)
    status: NDArray[np.int8]  # SWEET_PATH, DECAYING_PATH, NO_PATH
    reason: NDArray[np.int8]  # REASON_NONE, REASON_BLOCKED, REASON_NO_SWEET_PATH
    hops: IntArray
    sweet_hops: IntArray
    decaying_hops: IntArray
    path_length: FloatArray  # sum of hop tracking distances, cm; nan without a path
    offsets: IntArray  # (M + 1,): path m is nodes[offsets[m]:offsets[m + 1]]
    nodes: IntArray
    estimate: FloatArray  # (M, 3), cm; nan without a path
    truth: FloatArray  # (M, 3), cm
    distance_error: FloatArray  # percent; nan without a path
    alpha: FloatArray  # degrees
    theta: FloatArray  # degrees
    phi: FloatArray  # degrees
    sweet_connected: NDArray[np.bool_]  # an S_all path exists
    sweet_obstructed: NDArray[np.bool_]  # the policy's S_all path has an obstructed hop
    obstructing_flss: IntArray  # distinct obstructing FLSs on that path
    # Predicted error of the estimate, cm (core.hop_errors.expected_error); nan if unknown.
    predicted_error: FloatArray
    fused_paths: IntArray  # paths the estimate combines: 1, more when fused, 0 without a path
    # (M, 3, 3), cm^2: the estimate's covariance, where the estimator gives one (core.fit).
    covariance: FloatArray | None = None

    def __len__(self) -> int:
        return len(self.source)

    def path(self, pair: int) -> list[int]:
        """Swarm indices of the path of pair ``pair``; [] when it has none."""
        return [int(node) for node in self.nodes[self.offsets[pair] : self.offsets[pair + 1]]]

    def with_estimates(self, estimate: FloatArray, **changes: Any) -> PairResults:
        """These pairs with other estimates (M, 3), cm, and the errors that follow from them."""
        distance_error, alpha, theta, phi = pose_errors(estimate, self.truth)
        return replace(
            self,
            estimate=estimate,
            distance_error=distance_error,
            alpha=alpha,
            theta=theta,
            phi=phi,
            **changes,
        )


@dataclass(frozen=True)
class Evaluation:
    """One run: a swarm, a sensor, a policy, every ordered blind pair and the summary."""

    hood: Neighbourhood
    policy: str
    pairs: PairResults
    summary: Summary
