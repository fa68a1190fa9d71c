"""Sources' estimates read as the engine's evaluation, so that the swarm compares with it.

:func:`evaluation_of` turns every source's estimates into the engine's
evaluation; :class:`ReportedPairs` reads them a block of pairs at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ...core import csr
from ...core.arrays import IntArray
from ...core.evaluate import pair_results
from ...core.evaluation import NO_PATH, Evaluation, PairResults
from ...core.fit import SWARM_ESTIMATORS, consistency
from ...core.lookup import sorted_rows
from ...core.neighbourhood import Neighbourhood
from ...core.neighbours import ordered_blind_pairs
from ...core.pair_statistics import summarise
from ...core.path_arrays import Paths
from ...core.summary import FitFacts
from .estimate import Estimate, Estimates


def evaluation_of(
    hood: Neighbourhood, policy: str, found: Mapping[int, Sequence[Estimate]]
) -> Evaluation:
    """The evaluation that sources' estimates ({source id: estimates}) make, in engine pair order.

    Only the pairs that were reported count (a departed FLS reports none and
    is nobody's target); errors and obstruction follow from the geometry.
    A pair reported twice counts as its last report.
    """
    source, target = ordered_blind_pairs(hood.pairs)
    pairs, made = ReportedPairs(hood.swarm.cloud_index, found).read(hood, source, target)
    fit = None
    if len(made):
        # What made the fitted estimates: each source's own fit, or the swarm's.
        fit = FitFacts(SWARM_ESTIMATORS[int(made.max())], consistency(pairs))
    return Evaluation(hood, policy, pairs, summarise(hood, policy, pairs, fit=fit))


class ReportedPairs:
    """Sources' estimates ({source id: estimates}) read as the engine's pair results.

    All pairs at once (:func:`evaluation_of`) or a block of sources at a time
    (:meth:`pairs`), so that a swarm's results compare with the engine's
    block by block without every pair's results held at once.

    Parameters
    ----------
    ids : (N,) ndarray of int
        The swarm's FLS ids by index (``Swarm.cloud_index``).
    found : mapping of int to sequence of Estimate
        Each reporting source's estimates, by source id.
    """

    def __init__(self, ids: IntArray, found: Mapping[int, Sequence[Estimate]]) -> None:
        self._size = len(ids)
        self._rows_of = _rows_of(np.asarray(ids, dtype=np.int64))
        self._found = found
        self._reporter_ids = np.fromiter(found, dtype=np.int64, count=len(found))
        self._reporter_rows = self._rows_of(self._reporter_ids)

    def pairs(self, hood: Neighbourhood, source: IntArray, target: IntArray) -> PairResults:
        """The reported pairs among (``source``, ``target``) (M,) each, swarm indices, in
        their order; a pair nobody reported is left out.

        Raises
        ------
        ValueError
            A reported path hops between FLSs out of each other's reach in ``hood``.
        """
        return self.read(hood, source, target)[0]

    def read(
        self, hood: Neighbourhood, source: IntArray, target: IntArray
    ) -> tuple[PairResults, NDArray[np.int8]]:
        """:meth:`pairs`, and the estimator code of each fitted estimate among them."""
        asked = np.isin(self._reporter_rows, source)
        tables = [Estimates.of(self._found[int(fls)]) for fls in self._reporter_ids[asked]]
        everyone = Estimates.joined(tables)
        reporters = np.repeat(self._reporter_rows[asked], [len(t) for t in tables])
        rows_of, size = self._rows_of, self._size
        keys = reporters * size + rows_of(everyone.targets)
        order = np.argsort(keys, kind="stable")
        sorted_keys = keys[order]
        wanted = np.asarray(source, dtype=np.int64) * size + target
        at = np.searchsorted(sorted_keys, wanted, side="right") - 1
        # A block none of whose sources reported holds no keys: no pair is kept.
        keep = (at >= 0) & (
            sorted_keys[np.maximum(at, 0)] == wanted if len(sorted_keys) else False
        )
        source, target = source[keep], target[keep]
        kept = order[at[keep]]

        status = everyone.status[kept]
        reason = everyone.reason[kept]
        has_path = status != NO_PATH
        bounds, nodes = csr.take(everyone.path_offsets, everyone.path_ids, kept)
        counts = np.diff(bounds)
        counts[~has_path] = 0
        offsets = csr.offsets(counts)
        nodes = rows_of(nodes[csr.ragged_indices(bounds[:-1][has_path], counts[has_path])])
        paths = Paths(
            has_path,
            np.where(has_path, counts - 1, 0).astype(np.int64),
            np.where(has_path, everyone.length[kept], np.nan),
            offsets,
            nodes,
        )
        vectors = everyone.vector[kept]
        radio_bounds, radio_nodes = csr.take(everyone.radio_offsets, everyone.radio_ids, kept)
        radio_counts = np.diff(radio_bounds)
        connected = radio_counts > 0
        radio = Paths(
            np.ones(int(connected.sum()), dtype=bool),
            radio_counts[connected] - 1,
            np.full(int(connected.sum()), np.nan),
            csr.offsets(radio_counts[connected]),
            rows_of(radio_nodes),
        )
        pairs = pair_results(
            hood, source, target, status, reason, paths, vectors, radio, connected
        )
        covariance = everyone.covariance[kept]
        fitted = ~np.isnan(covariance).any(axis=(1, 2))
        if fitted.any():
            # The fit's estimates carry their covariance and predicted error (core.fit.refine).
            predicted = everyone.predicted_error[kept]
            pairs = pairs.with_estimates(vectors, predicted_error=predicted, covariance=covariance)
        return pairs, everyone.estimator[kept][fitted]


def _rows_of(ids: IntArray) -> Callable[[IntArray], IntArray]:
    """The row of each FLS id in ``ids`` (N,), as a function of ids (any shape)."""
    order = np.argsort(ids, kind="stable")
    ordered = ids[order]

    def rows(fls_ids: IntArray) -> IntArray:
        wanted = np.asarray(fls_ids, dtype=np.int64)
        at, found = sorted_rows(ordered, wanted)
        if not found.all():
            raise KeyError(int(wanted.reshape(-1)[~found][0]))
        return np.asarray(order[at], dtype=np.int64).reshape(wanted.shape)

    return rows
