"""Multi-path fusion: a pair's estimate from its k best node-disjoint sweet paths.

A sweet pair's estimate is the sum of the measured hops along one path.
Another path that shares no FLS with it (besides source and target) sums
other measurements, so its error is independent under a stochastic sensor,
and the two estimates can be combined by inverse-variance weighting. The
paths are found greedily: the policy's path first, then the policy's path
that avoids the inner FLSs of those before, up to ``count`` paths.

Each path's weight comes from the sum of its hops' expected errors
(:func:`~.hop_errors.hop_error`): a variance V under a stochastic sensor, so
the fused estimate is sum(x_k / V_k) / sum(1 / V_k) with variance
1 / sum(1 / V_k); a bound B under the deterministic one, weighted as
1 / B^2, whose fused error is bounded by sum(B_k / B_k^2) / sum(1 / B_k^2).
docs/core.md ("Predicted errors and multi-path fusion") derives both.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from . import csr
from .arrays import FloatArray, IntArray
from .avoiding import avoiding_paths
from .evaluation import SWEET_PATH, Evaluation, PairResults
from .hops import estimates, summed_hop_errors
from .neighbourhood import Neighbourhood
from .pair_statistics import EXACT_VALUES, summarise
from .path_arrays import Paths
from .sensor import Sensor
from .summary import FusionFacts
from .tally import RealTally


def inner_nodes(paths: Paths) -> tuple[IntArray, IntArray]:
    """Each path's nodes without its source and target: the FLSs a disjoint path avoids.

    Parameters
    ----------
    paths : Paths
        M paths as compressed rows of FLS indices.

    Returns
    -------
    offsets : (M + 1,) array of int
    nodes : array of int
        Path m's inner FLSs are ``nodes[offsets[m]:offsets[m + 1]]``, in path
        order; none for a path of one hop or none.
    """
    counts = np.diff(paths.offsets)
    inner = np.maximum(counts - 2, 0)
    keep = np.ones(len(paths.nodes), dtype=bool)
    ends = counts > 0
    keep[paths.offsets[:-1][ends]] = False
    keep[paths.offsets[1:][ends] - 1] = False
    offsets = csr.offsets(inner)
    return offsets, paths.nodes[keep]


def _joined(
    first: tuple[IntArray, IntArray], second: tuple[IntArray, IntArray]
) -> tuple[IntArray, IntArray]:
    """Two ragged lists (offsets, values) of M rows joined row by row."""
    counts = np.diff(first[0]) + np.diff(second[0])
    offsets = csr.offsets(counts)
    rows = np.concatenate([csr.run_of(part[0]) for part in (first, second)])
    values = np.concatenate([first[1], second[1]])
    order = np.argsort(rows, kind="stable")
    return offsets, values[order]


def combine(
    sensor: Sensor, vectors: FloatArray, summed: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Fuse K estimates of each of M pairs by inverse-variance weights.

    Under a stochastic sensor each path's weight is 1 / V (V its summed hop
    variances) and the fused error's deviation sqrt(1 / sum(1 / V)); under a
    deterministic one 1 / B^2 (B its summed bound) and the fused bound
    sum(B / B^2) / sum(1 / B^2). An exact path (V or B of 0) alone decides.

    Parameters
    ----------
    sensor : Sensor
        Says which of the two weightings.
    vectors : (K, M, 3) array of float, cm
        Each path's estimate of each pair.
    summed : (K, M) array of float
        Each path's summed :func:`~.hop_errors.hop_error` (cm^2 stochastic, cm
        deterministic); NaN where the pair has no k-th path. Every pair has
        at least one.

    Returns
    -------
    fused : (M, 3) array of float, cm
    predicted : (M,) array of float, cm
        The fused estimates' predicted errors.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.fusion import combine
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> vectors = np.array([[[10.0, 0, 0]], [[12.0, 0, 0]]])  # two paths of one pair
    >>> combine(published, vectors, np.array([[1.0], [2.0]]))  # bounds 1 and 2 cm
    (array([[10.4,  0. ,  0. ]]), array([1.2]))
    """
    found = np.isfinite(summed)
    stochastic = sensor.noise is not None
    variance = np.where(found, summed if stochastic else summed**2, np.inf)
    # An error-free path (variance 0) is exact: it alone decides.
    exact = found & (variance == 0)
    weight = np.where(exact.any(axis=0), exact.astype(float), 1.0 / variance)
    total = weight.sum(axis=0)
    fused = np.einsum("km,kmd->md", weight, np.where(found[..., None], vectors, 0.0))
    fused /= total[:, None]
    if stochastic:
        predicted = np.sqrt(1.0 / total)
    else:
        predicted = np.einsum("km,km->m", weight, np.where(found, summed, 0.0)) / total
    predicted = np.where(exact.any(axis=0), 0.0, predicted)
    return fused, predicted


def fuse(evaluation: Evaluation, count: int) -> Evaluation:
    """``evaluation`` with every sweet pair's estimate fused from up to ``count`` disjoint paths.

    The paths are found greedily in ``S_vis``: the policy's path, then the
    policy's path that avoids the inner FLSs of those before, and so on;
    disjoint paths share no measurement, so their errors are independent
    under a stochastic sensor (docs/core.md, "Predicted errors and
    multi-path fusion"). The reported path stays the policy's;
    ``fused_paths`` says how many were combined. The same as
    :class:`Fusion` of the pairs in one block.

    Parameters
    ----------
    evaluation : Evaluation
        A plain evaluation (``evaluate.evaluate``).
    count : int
        Paths per pair, at most; >= 1 (1 leaves the estimates as they are).

    Returns
    -------
    Evaluation
        With the sweet pairs' estimates, predicted errors and ``fused_paths``
        replaced, and a summary that gains ``fusion``: the pairs with two or
        more paths and their distance errors before and after.

    Raises
    ------
    ValueError
        ``count`` is below 1.

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points
    >>> from swazure_ros.core.evaluate import evaluate
    >>> from swazure_ros.core.fusion import fuse
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(builtin_points("torus:120") * 5, beta=0.5)
    >>> fused = fuse(evaluate(swarm, published, "shortest-length"), 3)
    >>> fused.summary.fusion.paths_per_pair  # sweet pairs by paths fused: 0, 1, 2, 3
    (0, 0, 0, 3378)
    """
    fusion = Fusion(count, evaluation.policy)
    updated = fusion.block(evaluation.hood, evaluation.pairs)
    summary = summarise(
        evaluation.hood, evaluation.policy, updated, evaluation.summary.seconds,
        fusion=fusion.facts(),
    )  # fmt: skip
    return replace(evaluation, pairs=updated, summary=summary)


@dataclass
class Fusion:
    """Fusion of a run's pairs, one block at a time, and its facts gathered as it goes.

    Each pair's fused estimate depends on its own paths only (one search per
    pair), so the blocks of a run made in blocks (:mod:`.blocks`) give the
    pairs of :func:`fuse` of the whole; the facts' statistics are tallied
    (exact while their values fit ``exact_values``, :class:`~.tally.RealTally`).
    """

    count: int  # paths per pair, at most
    policy: str
    exact_values: int = EXACT_VALUES
    pairs_fused: int = 0
    paths_per_pair: IntArray = field(init=False)
    one_path: RealTally = field(init=False)  # the fused pairs' distance errors, % ...
    fused: RealTally = field(init=False)  # ... before and after
    seconds: float = 0.0

    def __post_init__(self) -> None:
        if self.count < 1:
            raise ValueError(f"fusion needs at least one path per pair, got {self.count}")
        self.paths_per_pair = np.zeros(self.count + 1, dtype=np.int64)
        self.one_path = RealTally(self.exact_values)
        self.fused = RealTally(self.exact_values)

    def block(self, hood: Neighbourhood, pairs: PairResults) -> PairResults:
        """``pairs`` (a block of the run's) with their sweet pairs' estimates fused."""
        began = time.perf_counter()
        sweet = np.flatnonzero(pairs.status == SWEET_PATH)
        counts = np.diff(pairs.offsets)
        first = Paths(
            np.ones(len(sweet), dtype=bool),
            pairs.hops[sweet],
            pairs.path_length[sweet],
            csr.offsets(counts[sweet]),
            pairs.nodes[np.repeat(pairs.status == SWEET_PATH, counts)],
        )
        graph, components = hood.sweet_visible, hood.sweet_visible_components
        found_paths = [first]
        avoid = inner_nodes(first)
        for _ in range(self.count - 1):
            more = avoiding_paths(
                graph, pairs.source[sweet], pairs.target[sweet], self.policy, *avoid,
                components=components,
            )  # fmt: skip
            if not more.found.any():
                break
            found_paths.append(more)
            avoid = _joined(avoid, inner_nodes(more))
        vectors = np.stack([estimates(hood, paths)[0] for paths in found_paths])
        summed = np.stack([summed_hop_errors(hood, paths) for paths in found_paths])
        fused, predicted = combine(hood.sensor, vectors, summed)
        used = np.isfinite(summed).sum(axis=0)

        estimate = pairs.estimate.copy()
        estimate[sweet] = fused
        predicted_error = pairs.predicted_error.copy()
        predicted_error[sweet] = predicted
        fused_paths = pairs.fused_paths.copy()
        fused_paths[sweet] = used
        updated = pairs.with_estimates(
            estimate, predicted_error=predicted_error, fused_paths=fused_paths
        )
        several = fused_paths >= 2
        self.pairs_fused += int(several.sum())
        self.paths_per_pair += np.bincount(fused_paths[sweet], minlength=self.count + 1)
        self.one_path.add(pairs.distance_error[several])
        self.fused.add(updated.distance_error[several])
        self.seconds += time.perf_counter() - began
        return updated

    def facts(self) -> FusionFacts:
        """The summary's ``fusion``: of every block fused so far."""
        return FusionFacts(
            paths=self.count,
            pairs_fused=self.pairs_fused,
            paths_per_pair=tuple(self.paths_per_pair.tolist()),
            distance_error_pct_one_path=self.one_path.describe(),
            distance_error_pct_fused=self.fused.describe(),
            seconds=self.seconds,
        )
