"""The engine's least-squares estimates of many pairs: the whole swarm's fit, or each source's own.

:func:`fit_pairs_estimates` fits the whole swarm's measurements once (or
twice, under a deterministic sensor) and reads every pair off the fit, as
the least-squares and swarm-fit estimators do; :func:`local_estimates` fits
each source's window (:mod:`.window_fit`), as the local-least-squares
estimator does. Both give a :class:`PairFit`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from . import csr
from .arrays import FloatArray, IntArray
from .fit_measurements import Corruption, fit_layers, fit_pairs, measurements, select_rows
from .frames import through_metres
from .least_squares import solve
from .measurement_graph import (
    Measurements,
)
from .neighbourhood import Neighbourhood
from .sensor import (
    SWEET,
)
from .swarm_fit import swarm_solve
from .window_fit import heard_in_window, window_fit


@dataclass(frozen=True)
class PairFit:
    """The fit's estimates of M ordered pairs and what it took."""

    estimate: FloatArray  # (M, 3), cm, target - source; nan where no fit joins the two
    covariance: FloatArray  # (M, 3, 3), cm^2
    measurements: int  # measurements in the fits
    downweighted: int  # of them, those the robust loss weighed below one
    seconds: float
    # The swarm's fit: per fit (two under a deterministic sensor), the iterations of each
    # solve, the covariance's last.
    iterations: tuple[tuple[int, ...], ...] = ()


def fit_pairs_estimates(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
    corrupt: Corruption | None = None,
    swarm: bool = False,
) -> PairFit:
    """Least-squares estimates of the pairs (source[m], target[m]); ``sweet`` marks sweet pairs.

    Under a stochastic sensor one fit serves every pair: its bias is removed
    and its scatter known, so every joining decaying hop only adds what it
    knows. Under a deterministic one (the published quadratic, its bias
    unknown and alike on every hop) a pair with a sweet path is estimated
    from the sweet hops alone, and only the pairs that need a decaying hop
    from a fit with the joining decaying hops. ``corrupt`` alters the
    measurements before the fit (a test's or a benchmark's outliers). With
    ``swarm``, each fit is solved as the swarm solves it (:mod:`.swarm_fit`):
    the same estimates, and a covariance sampled by the swarm.
    """
    began = time.perf_counter()
    size = hood.swarm.size
    estimate = np.full((len(source), 3), np.nan)
    covariance = np.full((len(source), 3, 3), np.nan)
    index = fit_pairs(hood)
    # Measured once: the sweet-only fit takes its rows from the same table.
    every = measurements(hood, index)
    if corrupt is not None:
        every = corrupt(every)
    sweet_rows = np.tile(hood.pairs.range_class[index] == SWEET, 2)
    rows_of = {False: sweet_rows, True: np.ones(len(every), dtype=bool)}
    pairs_of = {(True,): [np.ones(len(source), dtype=bool)], (False, True): [sweet, ~sweet]}
    links = fit_layers(hood.sensor)
    groups = [(rows, rows_of[layer]) for rows, layer in zip(pairs_of[links], links, strict=True)]
    used = downweighted = 0
    iterations: list[tuple[int, ...]] = []
    for rows, chosen in groups:
        # The swarm solves every fit: no FLS knows that no pair of the swarm needs one.
        if not rows.any() and not swarm:
            continue
        measured = select_rows(every, chosen)
        if swarm:
            solved = swarm_solve(size, measured, robust, ids=hood.swarm.cloud_index)
            estimate[rows], covariance[rows] = solved.relative(source[rows], target[rows])
            iterations.append(tuple(solved.iterations))
        else:
            fit = solve(size, measured, robust)
            estimate[rows], covariance[rows] = fit.relative(source[rows], target[rows])
        used += len(measured)
        downweighted += solved.downweighted if swarm else fit.downweighted
    seconds = time.perf_counter() - began
    return PairFit(estimate, covariance, used, downweighted, seconds, tuple(iterations))


def local_estimates(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
    corrupt: Corruption | None = None,
) -> tuple[PairFit, FloatArray, IntArray]:
    """Every pair's estimate from its source's :func:`window_fit`; and per source (in the
    order of ``np.unique(source)``) the seconds of its fit and the FLSs of its window.

    The windows are laid out from :func:`~.observe.observations`, what every
    FLS's senses give its node, as the ``measurements`` messages carry them
    to a source (in metres: :func:`~.frames.through_metres`); swarm indices
    serve as FLS ids. ``corrupt`` alters every reading first (outliers).
    """
    from .observe import observations

    began = time.perf_counter()
    seen = observations(hood)
    # A fit weighs readings whose axes differ by 1e10: the last bit of a reading
    # moves an estimate by up to 1e-9 cm, so the engine reads what the wire carries.
    seen = replace(
        seen, vector=through_metres(seen.vector), distance=through_metres(seen.distance)
    )
    if corrupt is not None:
        rows = np.flatnonzero(seen.measured)
        owner = csr.run_of(seen.indptr)[rows]
        unused = np.zeros((len(rows), 3, 3))
        readings = Measurements(owner, seen.other[rows], seen.vector[rows], unused, unused)
        vector = seen.vector.copy()
        vector[rows] = corrupt(readings).vectors
        seen = replace(seen, vector=vector)
    ids = np.arange(hood.swarm.size, dtype=np.int64)
    estimate = np.full((len(source), 3), np.nan)
    covariance = np.full((len(source), 3, 3), np.nan)
    sources, counts = np.unique(source, return_counts=True)
    order = np.argsort(source, kind="stable")
    ends = np.cumsum(counts)
    seconds = np.zeros(len(sources))
    sizes = np.zeros(len(sources), dtype=np.int64)
    used = 0
    for slot, one in enumerate(sources):
        rows = order[ends[slot] - counts[slot] : ends[slot]]
        tick = time.perf_counter()
        members, heard = heard_in_window(seen, ids, int(one))
        estimate[rows], covariance[rows], measured = window_fit(
            hood.sensor, hood.swarm.radius, members, heard, target[rows], sweet[rows], robust
        )
        seconds[slot] = time.perf_counter() - tick
        sizes[slot] = len(members)
        used = max(used, measured)
    fit = PairFit(estimate, covariance, used, 0, time.perf_counter() - began)
    return fit, seconds, sizes
