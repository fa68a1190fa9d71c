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
from .arrays import BoolArray, FloatArray, IntArray
from .fit_measurements import Corruption, fit_groups, fit_pairs, measurements, select_rows
from .frames import through_metres
from .least_squares import Fit, dense_bytes, solve
from .measurement_graph import Measurements
from .neighbourhood import Neighbourhood
from .observe import Observations
from .progress import SILENT, Progress
from .sensor import SWEET
from .swarm_fit import SwarmFit, swarm_solve
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
    """Least-squares estimates of many pairs from a fit of the whole swarm's measurements.

    Under a stochastic sensor one fit serves every pair: its bias is removed
    and its scatter known, so every joining decaying hop only adds what it
    knows. Under a deterministic one (the published quadratic, its bias
    unknown and alike on every hop) a pair with a sweet path is estimated
    from the sweet hops alone, and only the pairs that need a decaying hop
    from a fit with the joining decaying hops.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    source, target : (M,) ndarray of int
        The pairs, swarm indices.
    sweet : (M,) ndarray of bool
        The pairs with a sweet path.
    robust : bool, optional
        Whether to reweight and reject outliers (:func:`~.least_squares.solve`).
    corrupt : callable, optional
        Alters the measurements before the fit (a test's or a benchmark's outliers).
    swarm : bool, optional
        Whether to solve as the swarm solves (:mod:`.swarm_fit`): the same
        estimates, and a covariance sampled by the swarm.

    Returns
    -------
    PairFit
        Each pair's estimate, cm, and covariance, cm^2, NaN where no fit
        joins its FLSs; the measurements and what the fits took.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, Sensor(6.0, 8.0, 8.0, 30.0))  # error-free
    >>> source, target, sweet = np.array([0, 2]), np.array([2, 0]), np.array([True, True])
    >>> fit_pairs_estimates(hood, source, target, sweet).estimate.round(9).tolist()
    [[4.0, 0.0, 0.0], [-4.0, 0.0, 0.0]]
    """
    fits = WholeFits(hood, robust, corrupt, swarm)
    estimate, covariance = fits.estimates(source, target, sweet)
    return fits.result(estimate, covariance)


#: A fit is solved densely (:func:`~.least_squares.solve`) when this many times its parts'
#: dense matrices (:func:`~.least_squares.dense_bytes`) fit the memory free: the factor, and
#: the working copies of its making.
DENSE_COPIES = 2


class WholeFits:
    """The whole swarm's fits, each solved once when first needed, read a block of pairs at a time.

    Every pair's estimate and covariance are read off the fit
    (``relative``), whatever other pairs are read with it: a run made in
    blocks (:mod:`.blocks`) gets the numbers :func:`fit_pairs_estimates`
    gives all pairs at once. Under a deterministic sensor the fit with the
    joining decaying hops is solved only when a pair without a sweet path
    asks (the swarm solves every fit, at once). With ``free`` bytes known
    and a dense fit larger (:data:`DENSE_COPIES`), the least-squares fit is
    solved as the swarm solves it (:func:`~.swarm_fit.swarm_solve`): the
    same positions to the conjugate gradients' tolerance, a sampled
    covariance.
    """

    def __init__(
        self,
        hood: Neighbourhood,
        robust: bool = True,
        corrupt: Corruption | None = None,
        swarm: bool = False,
        free: int | None = None,
        progress: Progress = SILENT,
    ) -> None:
        began = time.perf_counter()
        self.hood, self.robust, self.swarm, self.free = hood, robust, swarm, free
        self.every, self.sweet_rows = _measured_once(hood, corrupt)
        self.solved: dict[int, Fit | SwarmFit] = {}
        self.rows: dict[int, NDArray[np.bool_]] = {}  # each solved layer's rows of ``every``
        self.measurements = self.downweighted = 0
        self.seconds = time.perf_counter() - began
        if swarm:
            # The swarm solves every fit: no FLS knows that no pair of the swarm needs one.
            for layer, (_, chosen) in enumerate(self._groups(np.ones(1, dtype=bool))):
                self._solve(layer, chosen, progress)

    def _groups(self, sweet: NDArray[np.bool_]) -> list[tuple[BoolArray, BoolArray]]:
        """Each fit's pairs among those of ``sweet`` (M,), and its rows (fit_groups)."""
        linked = np.ones(len(self.every), dtype=bool)
        return fit_groups(self.hood.sensor, sweet, self.sweet_rows, linked)

    def _solve(self, layer: int, chosen: NDArray[np.bool_], progress: Progress) -> Fit | SwarmFit:
        """Fit ``layer`` of :func:`~.fit_measurements.fit_layers`, solved once, its solves shown
        as stages of ``progress``."""
        if layer not in self.solved:
            began = time.perf_counter()
            same = [other for other, rows in self.rows.items() if np.array_equal(rows, chosen)]
            # No decaying hop joins the sweet fit's parts (a surface; a shape within the
            # sweet range): the same rows, the same fit to the bit, solved once. Its facts
            # count once a layer, as the swarm's do, which solves each layer.
            solved = self.solved[same[0]] if same else self._solved(chosen, progress)
            self.solved[layer], self.rows[layer] = solved, chosen
            self.measurements += int(chosen.sum())
            self.downweighted += solved.downweighted
            self.seconds += time.perf_counter() - began
        return self.solved[layer]

    def _solved(self, chosen: NDArray[np.bool_], progress: Progress) -> Fit | SwarmFit:
        """The fit of the rows ``chosen`` of every measurement, solved now."""
        measured = select_rows(self.every, chosen)
        size, ids = self.hood.swarm.size, self.hood.swarm.cloud_index
        dense = self.free is None or DENSE_COPIES * dense_bytes(size, measured) <= self.free
        if dense and not self.swarm:
            return solve(size, measured, self.robust, progress)
        # The swarm's fit, or a dense inverse that would not fit: the same normal equations
        # by conjugate gradients, without a factor (SuperLU's fill took over 10 min for
        # torus:30000's first factor), the covariance sampled.
        return swarm_solve(size, measured, self.robust, ids=ids, progress=progress)

    def estimates(
        self,
        source: IntArray,
        target: IntArray,
        sweet: NDArray[np.bool_],
        progress: Progress = SILENT,
    ) -> tuple[FloatArray, FloatArray]:
        """Estimates (M, 3), cm, and covariances (M, 3, 3), cm^2, of some pairs; NaN where no
        fit joins a pair's FLSs. ``sweet`` (M,): the pairs with a sweet path. A fit these
        pairs are the first to need is solved now, its solves shown on ``progress``."""
        began, counted = time.perf_counter(), self.seconds
        estimate, covariance = _unknown(len(source))
        for layer, (rows, chosen) in enumerate(self._groups(sweet)):
            if not rows.any():
                continue
            fit = self._solve(layer, chosen, progress)
            estimate[rows], covariance[rows] = fit.relative(source[rows], target[rows])
        # A fit solved here has counted its own seconds (_solve): each second once.
        solving = self.seconds - counted
        self.seconds += time.perf_counter() - began - solving
        return estimate, covariance

    @property
    def iterations(self) -> tuple[tuple[int, ...], ...]:
        """The swarm's fits: per fit, in order, the iterations of each solve; () otherwise."""
        if not self.swarm:
            return ()
        solved = [self.solved[layer] for layer in sorted(self.solved)]
        return tuple(tuple(fit.iterations) for fit in solved if isinstance(fit, SwarmFit))

    def result(self, estimate: FloatArray, covariance: FloatArray) -> PairFit:
        """A :class:`PairFit` of these estimates, with what the fits took so far."""
        return PairFit(
            estimate, covariance, self.measurements, self.downweighted, self.seconds,
            self.iterations,
        )  # fmt: skip


def _measured_once(
    hood: Neighbourhood, corrupt: Corruption | None
) -> tuple[Measurements, NDArray[np.bool_]]:
    """Every measurement a fit may take, altered by ``corrupt``, and which are sweet.

    Measured once: the sweet-only fit takes its rows from the same table.
    """
    index = fit_pairs(hood)
    every = measurements(hood, index)
    if corrupt is not None:
        every = corrupt(every)
    return every, np.tile(hood.pairs.range_class[index] == SWEET, 2)


def _unknown(count: int) -> tuple[FloatArray, FloatArray]:
    """Estimates (count, 3), cm, and covariances (count, 3, 3), cm^2, all NaN: none made yet."""
    return np.full((count, 3), np.nan), np.full((count, 3, 3), np.nan)


def local_estimates(
    hood: Neighbourhood,
    source: IntArray,
    target: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
    corrupt: Corruption | None = None,
) -> tuple[PairFit, FloatArray, IntArray]:
    """Every pair's estimate from its source's own fit (:func:`~.window_fit.window_fit`).

    The windows are laid out from :func:`~.observe.observations`, what every
    FLS's senses give its node, as the ``measurements`` messages carry them
    to a source (in metres: :func:`~.frames.through_metres`); swarm indices
    serve as FLS ids.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    source, target : (M,) ndarray of int
        The pairs, swarm indices.
    sweet : (M,) ndarray of bool
        The pairs with a sweet path.
    robust : bool, optional
        Whether to reweight and reject outliers (:func:`~.least_squares.solve`).
    corrupt : callable, optional
        Alters every reading first (a test's or a benchmark's outliers).

    Returns
    -------
    fit : PairFit
        Each pair's estimate, cm, and covariance, cm^2, NaN where the window
        does not join the pair; ``measurements``: the largest fit's readings.
    seconds : (S,) ndarray of float, s
        Per source, in the order of ``np.unique(source)``, its fit's time.
    window_flss : (S,) ndarray of int
        Per source, the FLSs of its window.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, Sensor(6.0, 8.0, 8.0, 30.0))  # error-free
    >>> source, target, sweet = np.array([0, 2]), np.array([2, 0]), np.array([True, True])
    >>> fit, seconds, window_flss = local_estimates(hood, source, target, sweet)
    >>> fit.estimate.round(9).tolist(), window_flss.tolist()
    ([[4.0, 0.0, 0.0], [-4.0, 0.0, 0.0]], [3, 3])
    """
    began = time.perf_counter()
    seen = _readings_as_sent(hood, corrupt)
    ids = np.arange(hood.swarm.size, dtype=np.int64)
    estimate, covariance = _unknown(len(source))
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


def _readings_as_sent(hood: Neighbourhood, corrupt: Corruption | None) -> Observations:
    """What every FLS observes, its readings through metres as the wire carries them, and
    altered by ``corrupt``."""
    from .observe import observations

    seen = observations(hood)
    # A fit weighs readings whose axes differ by 1e10: the last bit of a reading
    # moves an estimate by up to 1e-9 cm, so the engine reads what the wire carries.
    seen = replace(
        seen,
        readings_vector=through_metres(seen.readings_vector),
        distance=through_metres(seen.distance),
    )
    if corrupt is not None:
        rows = np.flatnonzero(seen.measured)
        owner = csr.run_of(seen.indptr)[rows]
        unused = np.zeros((len(rows), 3, 3))
        readings = Measurements(owner, seen.other[rows], seen.vector_at(rows), unused, unused)
        vector = seen.readings_vector.copy()
        vector[seen.reading[rows]] = corrupt(readings).vectors
        seen = replace(seen, readings_vector=vector)
    return seen
