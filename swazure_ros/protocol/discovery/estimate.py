"""What a source makes of its phases' results: section 5 of the spec, pair by pair.

:func:`estimate` turns one target's phase results (:class:`Found`) into the
pair's status, reason and path, as section 5 orders the phases;
:func:`evaluation_of` turns every source's estimates into the engine's
evaluation, so that the swarm's results compare with the engine's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ...core.evaluate import (
    DECAYING_PATH,
    NO_PATH,
    REASON_BLOCKED,
    REASON_NO_SWEET_PATH,
    REASON_NONE,
    SWEET_PATH,
    Evaluation,
    Neighbourhood,
    pair_results,
    summarise,
)
from ...core.fit import LOCAL_LEAST_SQUARES, PATH, consistency
from ...core.neighbours import ordered_blind_pairs
from ...core.paths import paths_from_rows
from ...core.sensor import (
    Sensor,
    expected_error,
)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True)
class Found:
    """A path from a source to one FLS: ids, hops, length (cm) and summed vector (3,), cm."""

    path: tuple[int, ...]
    length: float
    vector: FloatArray
    error: float = float("nan")  # the hops' expected errors summed (core.sensor.hop_error)
    unbiased: FloatArray | None = None  # (3,), cm: the hops less their known bias, summed
    covariance: FloatArray | None = None  # (3, 3), cm^2: the hops' covariances summed

    @property
    def hops(self) -> int:
        """Number of hops."""
        return len(self.path) - 1


@dataclass(frozen=True)
class Estimate:
    """A source's pose relative to one target: status, reason, path and summed vector."""

    target: int
    status: int  # SWEET_PATH, DECAYING_PATH or NO_PATH
    reason: int  # REASON_NONE, REASON_BLOCKED or REASON_NO_SWEET_PATH
    path: tuple[int, ...] = ()
    length: float = float("nan")  # cm
    vector: FloatArray = field(default_factory=lambda: np.full(3, np.nan))  # cm
    radio_path: tuple[int, ...] = ()  # the policy's S_all path (obstruction statistics)
    predicted_error: float = float("nan")  # cm (core.sensor.expected_error); nan without path
    estimator: str = PATH  # what made ``vector``: one of core.fit.SWARM_ESTIMATORS
    covariance: FloatArray | None = None  # (3, 3), cm^2, of ``vector``: a fit's only

    @property
    def hops(self) -> int:
        """Number of hops; 0 without a path."""
        return max(len(self.path) - 1, 0)


def estimate(
    target: int,
    sweet: Found | None,
    radio: Found | None,
    decaying: Found | None,
    sensor: Sensor | None = None,
) -> Estimate:
    """Section 5 of the spec for one target, from its S_vis, S_all and SD_vis results.

    With ``sensor``, the estimate's predicted error follows from its path's
    summed hop errors.
    """
    radio_path = radio.path if radio is not None else ()

    def predicted(found: Found) -> float:
        return float("nan") if sensor is None else float(expected_error(sensor, found.error))

    if sweet is not None:
        return Estimate(
            target,
            SWEET_PATH,
            REASON_NONE,
            sweet.path,
            sweet.length,
            sweet.vector,
            radio_path,
            predicted(sweet),
        )
    reason = REASON_BLOCKED if radio is not None else REASON_NO_SWEET_PATH
    if decaying is not None:
        return Estimate(
            target,
            DECAYING_PATH,
            reason,
            decaying.path,
            decaying.length,
            decaying.vector,
            radio_path,
            predicted(decaying),
        )
    return Estimate(target, NO_PATH, reason, radio_path=radio_path)


def evaluation_of(
    hood: Neighbourhood, policy: str, found: dict[int, list[Estimate]]
) -> Evaluation:
    """The evaluation that sources' estimates ({source id: estimates}) make, in engine pair order.

    Only the pairs that were reported count (a departed FLS reports none and
    is nobody's target); errors and obstruction follow from the geometry.
    """
    ids = hood.swarm.cloud_index
    by_pair = {
        (source, one.target): one for source, estimates in found.items() for one in estimates
    }
    source, target = ordered_blind_pairs(hood.pairs)
    keys = zip(ids[source].tolist(), ids[target].tolist(), strict=True)
    reported = [by_pair.get(key) for key in keys]
    keep = np.array([one is not None for one in reported], dtype=bool)
    source, target = source[keep], target[keep]
    kept = [one for one in reported if one is not None]
    count = len(kept)

    row_of = {fls: row for row, fls in enumerate(ids.tolist())}

    def indices(path: tuple[int, ...]) -> list[int]:
        return [row_of[fls] for fls in path]

    status = np.array([one.status for one in kept], dtype=np.int8)
    reason = np.array([one.reason for one in kept], dtype=np.int8)
    paths = paths_from_rows(
        count,
        {m: indices(one.path) for m, one in enumerate(kept) if one.status != NO_PATH},
        {m: one.length for m, one in enumerate(kept) if one.status != NO_PATH},
    )
    vectors = np.array([one.vector for one in kept], dtype=np.float64).reshape(count, 3)
    connected = np.array([bool(one.radio_path) for one in kept], dtype=bool)
    radio_rows = [indices(one.radio_path) for one in kept if one.radio_path]
    radio = paths_from_rows(len(radio_rows), dict(enumerate(radio_rows)))
    pairs = pair_results(hood, source, target, status, reason, paths, vectors, radio, connected)
    fitted = np.array([one.covariance is not None for one in kept], dtype=bool)
    if fitted.any():
        # The fit's estimates carry their covariance and predicted error (core.fit.refine).
        covariance = np.full((count, 3, 3), np.nan)
        covariance[fitted] = [one.covariance for one in kept if one.covariance is not None]
        predicted = np.array([one.predicted_error for one in kept], dtype=np.float64)
        pairs = pairs.with_estimates(vectors, predicted_error=predicted, covariance=covariance)
    summary = summarise(hood, policy, pairs)
    if fitted.any():
        summary["estimator"] = summary["parameters"]["estimator"] = LOCAL_LEAST_SQUARES
        summary["fit"] = consistency(pairs)
    return Evaluation(hood, policy, pairs, summary)
