"""Statistics of a run's pairs accumulated block by block, in bounded memory.

A run at display scale has tens of millions of pairs, evaluated a block at a
time (:mod:`.blocks`); the summary (spec, section 6) is gathered from each
block as it is made and the block is let go. Counts, sums, maxima and the
quantiles of integers (hops, obstructing FLSs) are exact by histograms.
Quantiles of real numbers are exact while their values fit the tally's
``exact_values``; past that they come from a mergeable logarithmic sketch
whose answers are within :data:`SKETCH_RELATIVE_ERROR` of the true order
statistic (the idea of DDSketch, Masson et al., VLDB 2019).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray, IntArray
from .metrics import Stats, describe

#: Largest relative error of a sketched quantile against the order statistic it stands for.
SKETCH_RELATIVE_ERROR = 1e-4
_GAMMA = (1.0 + SKETCH_RELATIVE_ERROR) / (1.0 - SKETCH_RELATIVE_ERROR)
_LOG_GAMMA = math.log(_GAMMA)
#: Values below this (cm, %, degrees) are counted as zero by the sketch.
SKETCH_FLOOR = 1e-12
QUANTILES = (50.0, 90.0, 99.0)


def _lerp(low: float, high: float, fraction: float) -> float:
    """numpy.percentile's linear interpolation, to the same rounding."""
    difference = high - low
    if fraction >= 0.5:
        return high - difference * (1.0 - fraction)
    return low + difference * fraction


def _from_order(order_statistic: Any, count: int) -> list[float]:
    """Percentiles QUANTILES by linear interpolation between order statistics (0-based)."""
    out = []
    for quantile in QUANTILES:
        position = quantile / 100.0 * (count - 1)
        low = math.floor(position)
        high = min(low + 1, count - 1)
        out.append(_lerp(order_statistic(low), order_statistic(high), position - low))
    return out


@dataclass
class IntegerTally:
    """Counts of non-negative integers (hops, FLSs): mean, max and quantiles exact."""

    counts: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def add(self, values: ArrayLike) -> None:
        """Count ``values`` (M,), non-negative integers."""
        found = np.bincount(np.asarray(values, dtype=np.int64))
        if len(found) > len(self.counts):
            found[: len(self.counts)] += self.counts
            self.counts = found
        else:
            self.counts[: len(found)] += found

    def describe(self) -> Stats:
        """As :func:`.metrics.describe` of every value added."""
        count = int(self.counts.sum())
        if count == 0:
            return describe([])
        ends = np.cumsum(self.counts)
        values = np.arange(len(self.counts), dtype=np.float64)

        def order_statistic(rank: int) -> float:
            return float(values[np.searchsorted(ends, rank, side="right")])

        p50, p90, p99 = _from_order(order_statistic, count)
        return Stats(
            mean=float(np.dot(self.counts, values)) / count,
            max=float(np.flatnonzero(self.counts)[-1]),
            p50=p50,
            p90=p90,
            p99=p99,
            count=count,
        )


@dataclass
class RealTally:
    """Non-negative reals (errors): kept while they fit ``exact_values``, then sketched."""

    exact_values: int
    kept: list[FloatArray] = field(default_factory=list)
    kept_count: int = 0
    count: int = 0
    sums: list[float] = field(default_factory=list)
    largest: float = -math.inf
    unknown: bool = False  # a NaN was added: every statistic is NaN, as numpy's
    zeros: int = 0
    buckets: dict[int, int] = field(default_factory=dict)

    @property
    def exact(self) -> bool:
        """Whether the quantiles are exact (every value is still kept)."""
        return self.count == self.kept_count

    def add(self, values: ArrayLike) -> None:
        """Add ``values`` (M,), non-negative and finite."""
        values = np.asarray(values, dtype=np.float64)
        if len(values) == 0:
            return
        keep = self.exact and self.kept_count + len(values) <= self.exact_values
        self.count += len(values)
        if np.isnan(values).any():
            self.unknown = True
        self.sums.append(float(values.sum()))
        self.largest = max(self.largest, float(values.max()))
        if keep:
            self.kept.append(values.copy())
            self.kept_count += len(values)
            return
        for kept in self.kept:
            self._sketch(kept)
        self.kept, self.kept_count = [], 0
        self._sketch(values)

    def _sketch(self, values: FloatArray) -> None:
        values = values[~np.isnan(values)]
        small = values < SKETCH_FLOOR
        self.zeros += int(small.sum())
        index = np.ceil(np.log(values[~small]) / _LOG_GAMMA).astype(np.int64)
        if not len(index):
            return
        # Counted, not sorted: the buckets span a few thousand keys, a block a million values.
        lowest = int(index.min())
        counts = np.bincount(index - lowest)
        for offset in np.flatnonzero(counts).tolist():
            key = lowest + offset
            self.buckets[key] = self.buckets.get(key, 0) + int(counts[offset])

    def describe(self) -> Stats:
        """As :func:`.metrics.describe` of every value added (quantiles sketched if not exact)."""
        if self.count == 0:
            return describe([])
        if self.exact:
            return describe(np.concatenate(self.kept))
        if self.unknown:
            nan = float("nan")
            return Stats(mean=nan, max=nan, p50=nan, p90=nan, p99=nan, count=self.count)
        keys = np.array(sorted(self.buckets), dtype=np.int64)
        ends = self.zeros + np.cumsum([self.buckets[key] for key in keys.tolist()])
        # The middle of bucket i, (gamma^(i-1), gamma^i], in relative terms.
        middles = 2.0 * np.power(_GAMMA, keys.astype(np.float64)) / (_GAMMA + 1.0)

        def order_statistic(rank: int) -> float:
            if rank < self.zeros:
                return 0.0
            return min(float(middles[np.searchsorted(ends, rank, side="right")]), self.largest)

        p50, p90, p99 = _from_order(order_statistic, self.count)
        return Stats(
            mean=math.fsum(self.sums) / self.count,
            max=self.largest,
            p50=p50,
            p90=p90,
            p99=p99,
            count=self.count,
        )
