"""The swarm's own least-squares fit: every FLS's position from messages with its neighbours only.

:func:`~.least_squares.solve` finds every position from every measurement at once, in
one place. Here the same weighted normal equations ``H x = b`` are solved
by the swarm: each FLS holds its own three unknowns, the rows of ``H`` and
``b`` its own measured pairs give, and per iteration exchanges one vector
with the FLSs it measures and adds two numbers to a sum over the swarm.
The method is conjugate gradients preconditioned by each FLS's own 3 x 3
block (block Jacobi) in Chronopoulos and Gear's form, which needs one
exchange and one sum per iteration; the robust loss reweights between
solves as :func:`~.least_squares.solve` does, each solve starting where the last
ended. docs/core.md ("The swarm's fit") says why conjugate gradients and
not Gaussian belief propagation, and how it converges.

The pairs' edges are in :mod:`.swarm_edges` and the iterations in
:mod:`.conjugate_gradients`; here are the fit's weights, its robust schedule
and its covariance's draws. Every function works on one FLS's rows as on the
whole swarm's, so a node and the engine run the same arithmetic; the sums over
the swarm are :func:`math.fsum`, exact, so the order in which processes add
them changes nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arrays import FloatArray, IntArray
from .conjugate_gradients import solved, system_of
from .draws import standard_normals
from .measurement_graph import (
    CONVERGED_CM,
    ROBUST_ROUNDS,
    Measurements,
    parts_of,
    robust_weights,
)
from .progress import SILENT, Progress
from .swarm_edges import FLOW_CHUNK, Edges, blocks_times, edges_of, flows, summed_flows, weighted

#: Right sides of the covariance's solve: each a draw of every measurement's noise. The
#: sample covariance of K solutions is the fit's covariance to about sqrt(2 / K); a NEES
#: taken with it averages 3 K / (K - 4), the inverse of a sample covariance being biased.
COVARIANCE_SAMPLES = 64
#: The seed of those draws; each measurement's are fixed by it and its two FLS ids.
SAMPLE_SEED = 5


@dataclass(frozen=True)
class SwarmFit:
    """The swarm's fit: positions, and what the swarm spent on them."""

    positions: FloatArray  # (N, 3), cm, relative to the smallest index of the FLS's part
    part: IntArray  # (N,), connected part of the measurement graph; -1 for an FLS alone
    iterations: list[int]  # per solve: its iterations (one exchange and one sum each)
    downweighted: int  # measurements the robust loss weighed below one in the end
    samples: FloatArray  # (N, 3, K), cm: the covariance's solutions; K = 0 without them

    @property
    def solves(self) -> int:
        return len(self.iterations)

    def relative(self, source: IntArray, target: IntArray) -> tuple[FloatArray, FloatArray]:
        """Each target's position relative to its source, and its sample covariance.

        Parameters
        ----------
        source, target : (M,) array of int
            Swarm indices.

        Returns
        -------
        estimate : (M, 3) array of float, cm
            x_target - x_source; NaN across parts or for an FLS in none.
        covariance : (M, 3, 3) array of float, cm^2
            The sample covariance over the fit's samples; NaN without samples.
        """
        same = (self.part[source] == self.part[target]) & (self.part[source] >= 0)
        estimate = np.full((len(source), 3), np.nan)
        estimate[same] = self.positions[target[same]] - self.positions[source[same]]
        covariance = np.full((len(source), 3, 3), np.nan)
        if self.samples.shape[2]:
            rows = np.flatnonzero(same)
            # A chunk of pairs at a time: each pair's K differences gathered whole would be
            # 1.5 KB a pair at K = 64, gigabytes a block at a display's size; each pair's
            # covariance is its own product, so the bits are those of all at once.
            for start in range(0, len(rows), FLOW_CHUNK):
                chunk = rows[start : start + FLOW_CHUNK]
                spread = self.samples[target[chunk]] - self.samples[source[chunk]]
                covariance[chunk] = sample_covariance(spread)
        return estimate, covariance


def sample_covariance(spread: FloatArray) -> FloatArray:
    """The sample covariance of each pair's K sampled differences.

    Parameters
    ----------
    spread : (M, 3, K) array of float, cm
        Each pair's samples, target's less source's.

    Returns
    -------
    (M, 3, 3) array of float, cm^2
        Zero without samples (K = 0).
    """
    count = spread.shape[2]
    return np.asarray(np.matmul(spread, np.swapaxes(spread, 1, 2)) / max(count, 1))


#: How a solve weighs the measurements: all alike, by Huber's loss, or rejecting those far out.
UNIT, HUBER, REJECTING = 0, 1, 2


def weights_for(measured: Measurements, positions: FloatArray, mode: int) -> FloatArray:
    """The weight of each measurement under ``mode`` at ``positions``.

    Parameters
    ----------
    measured : Measurements
        M rows.
    positions : (N, 3) array of float, cm
    mode : {UNIT, HUBER, REJECTING}

    Returns
    -------
    (M,) array of float
        Ones for UNIT; :func:`~.measurement_graph.robust_weights` otherwise.
    """
    if mode == UNIT:
        return np.ones(len(measured))
    return robust_weights(measured, positions, rejecting=mode == REJECTING)


def robust_decision(
    rejecting: bool, huber_same: bool, rejecting_same: bool, solves: int
) -> int | None:
    """The weights of the next solve (HUBER or REJECTING), or None: the fit is done.

    :func:`~.least_squares.solve`'s schedule: Huber's weights until they repeat, then
    rejection until the rejected set repeats, at most ``ROBUST_ROUNDS``
    reweightings. ``*_same``: whether each mode's weights at the last
    solution equal the weights it was solved with (over the swarm, every FLS's
    say). The engine and the coordinator both decide here.

    Parameters
    ----------
    rejecting : bool
        Whether the last solve rejected (past Huber's loss).
    huber_same, rejecting_same : bool
        Whether each mode's weights repeat.
    solves : int
        Solves so far.

    Returns
    -------
    int or None
        HUBER or REJECTING, or None.

    Examples
    --------
    >>> from swazure_ros.core.swarm_fit import HUBER, REJECTING, robust_decision
    >>> robust_decision(False, False, False, 1) == HUBER  # Huber's weights changed
    True
    >>> robust_decision(False, True, False, 2) == REJECTING  # they repeat: now reject
    True
    >>> robust_decision(True, True, True, 3) is None  # the rejected set repeats: done
    True
    """
    if solves > ROBUST_ROUNDS:
        return None
    if not rejecting:
        if not huber_same:
            return HUBER
        rejecting = True
    return None if rejecting_same else REJECTING


def swarm_solve(
    size: int,
    measured: Measurements,
    robust: bool = True,
    start: FloatArray | None = None,
    samples: int = COVARIANCE_SAMPLES,
    ids: IntArray | None = None,
    progress: Progress = SILENT,
) -> SwarmFit:
    """The fit of ``size`` FLSs from ``measured`` by the swarm's iterations; see the module.

    The robust loss follows :func:`robust_decision`, each solve from the last
    one's positions. ``start`` (N, 3), cm: where the first solve starts (a
    swarm that moved starts from its last fit, a warm start); zero by
    default. Then one more solve with ``samples`` right sides, each a draw of
    every measurement's noise at its final weight, whose solutions' spread is
    the fit's covariance (:func:`noise_flows`).

    Parameters
    ----------
    size : int
        FLSs, N.
    measured : Measurements
        M rows, each pair measured from both ends.
    robust : bool, default True
        Reweight by the robust loss; False: one solve at unit weights.
    start : (N, 3) array of float, optional, cm
        Where the first solve starts (NaN rows: 0).
    samples : int, default COVARIANCE_SAMPLES (64)
        Right sides of the covariance's solve; 0 for none.
    ids : (N,) array of int, optional
        The FLS ids the draws are keyed by; the indices by default.
    progress : Progress, optional
        Told of each solve as a stage of its own, in hundredths of the way to
        settled (:func:`~.conjugate_gradients.solved`).

    Returns
    -------
    SwarmFit
        Positions (N, 3), cm, each part's FLS of the smallest index at the
        origin; the iterations of every solve; the samples.

    Raises
    ------
    ValueError
        A pair measured from one end only (:func:`~.swarm_edges.edges_of`).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> points = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 0]])  # cm
    >>> first, second = np.array([0, 1, 2, 1, 0, 2]), np.array([1, 2, 0, 0, 2, 1])
    >>> eye = np.broadcast_to(np.eye(3), (6, 3, 3))  # each measurement's variance: 1 cm^2
    >>> measured = Measurements(first, second, points[second] - points[first], eye, eye)
    >>> from swazure_ros.core.swarm_fit import swarm_solve
    >>> fit = swarm_solve(3, measured, samples=0)
    >>> fit.positions.round(9)
    array([[0., 0., 0.],
           [7., 0., 0.],
           [0., 7., 0.]])
    >>> estimate, _ = fit.relative(np.array([1]), np.array([2]))
    >>> estimate.round(9)
    array([[-7.,  7.,  0.]])
    """
    ids = np.arange(size, dtype=np.int64) if ids is None else ids
    edges = edges_of(size, measured)
    position = np.zeros((size, 3, 1))
    if start is not None:
        position[:, :, 0] = np.nan_to_num(start)
    position, spent = solved(system_of(edges), position, progress=progress, stage="fit: solve 1")
    iterations = [spent]
    weights = weights_for(measured, position[:, :, 0], UNIT)
    rejecting = False
    while robust:
        at = position[:, :, 0]
        candidates = {mode: weights_for(measured, at, mode) for mode in (HUBER, REJECTING)}
        mode = robust_decision(
            rejecting,
            np.array_equal(candidates[HUBER], weights),
            np.array_equal(candidates[REJECTING], weights),
            len(iterations),
        )
        if mode is None:
            break
        rejecting = mode == REJECTING
        weights = candidates[mode]
        before = position
        system = system_of(weighted(edges, measured, weights))
        loss = "Huber's" if mode == HUBER else "rejecting"
        stage = f"fit: solve {len(iterations) + 1}, {loss} weights"
        position, spent = solved(system, position, progress=progress, stage=stage)
        iterations.append(spent)
        if np.abs(position - before).max(initial=0.0) <= CONVERGED_CM:
            # Huber's loss has settled: from here on, measurements far out are rejected.
            rejecting = True
    part = parts_of(size, measured)
    positions = gauged(position[:, :, 0], part)
    drawn = np.zeros((size, 3, 0))
    if samples:
        final = weighted(edges, measured, weights)
        system = system_of(final, right=noise_sides(final, measured, weights, samples, ids))
        stage = f"fit: covariance, {samples} draws"
        drawn, spent = solved(system, np.zeros((size, 3, samples)), progress=progress, stage=stage)
        iterations.append(spent)
    return SwarmFit(positions, part, iterations, int((weights < 1.0).sum()), drawn)


def noise_flows(
    edges: Edges, measured: Measurements, weights: FloatArray, samples: int, ids: IntArray
) -> FloatArray:
    """Edge flows (2E, 3, K) of K draws of every measurement's noise, N(0, C_m / w_m).

    The fit's solution is linear in the measurements, so the solutions of
    these right sides spread as the fit's errors do: their sample covariance
    estimates H^-1 without forming it. Each measurement's draws are fixed by
    ``SAMPLE_SEED`` and its two FLS ids, so an FLS draws its neighbour's too.

    Parameters
    ----------
    edges : Edges
    measured : Measurements
        M rows.
    weights : (M,) array of float
        The final robust weights.
    samples : int
        Draws, K.
    ids : (N,) array of int
        The FLS id of each index.

    Returns
    -------
    (2E, 3, K) array of float, cm^-1
    """
    return flows(edges, measured, *_noise_parts(edges, measured, weights, samples, ids))


def noise_sides(
    edges: Edges, measured: Measurements, weights: FloatArray, samples: int, ids: IntArray
) -> FloatArray:
    """The right sides of :func:`noise_flows`: each FLS's flows of the noise, summed.

    The same bits as ``sums_into(noise_flows(...), edges.starts)``, without every
    edge's K columns at once (:func:`~.swarm_edges.summed_flows`).

    Parameters
    ----------
    edges : Edges
    measured : Measurements
        M rows.
    weights : (M,) array of float
        The final robust weights.
    samples : int
        Draws, K.
    ids : (N,) array of int
        The FLS id of each index.

    Returns
    -------
    (N, 3, K) array of float, cm^-1
    """
    return summed_flows(edges, measured, *_noise_parts(edges, measured, weights, samples, ids))


def _noise_parts(
    edges: Edges, measured: Measurements, weights: FloatArray, samples: int, ids: IntArray
) -> tuple[FloatArray, FloatArray]:
    """Each edge's two rows' weighted information (2E, 2, 3, 3) and the rows' noise draws
    (M, 3, K): what an edge's flow of noise is formed from."""
    information = measured.information[edges.rows] * weights[edges.rows][:, :, None, None]
    return information, measurement_noise(measured, weights, samples, ids)


def measurement_noise(
    measured: Measurements, weights: FloatArray, samples: int, ids: IntArray
) -> FloatArray:
    """K draws (M, 3, K), cm, of each measurement's noise, N(0, C_m / w_m).

    Each row's draws are fixed by ``SAMPLE_SEED`` and its two FLS ids, so the
    rows drawn a few at a time draw what they draw all at once.

    Parameters
    ----------
    measured : Measurements
        M rows.
    weights : (M,) array of float
        Their final robust weights.
    samples : int
        Draws, K.
    ids : (N,) array of int
        The FLS id of each index.

    Returns
    -------
    (M, 3, K) array of float, cm
    """
    values, axes = np.linalg.eigh(measured.covariance)
    root = blocks_times(
        axes * np.sqrt(np.maximum(values, 0.0))[:, None, :], np.swapaxes(axes, 1, 2)
    )
    first, second = ids[measured.first], ids[measured.second]
    noise = np.empty((len(root), 3, samples), dtype=np.float64)
    # Rows a chunk at a time: each row's draws are its own, so the bits are those of all
    # rows at once, and the normals' temporaries are held for one chunk.
    for start in range(0, len(root), FLOW_CHUNK):
        part = slice(start, start + FLOW_CHUNK)
        normals = standard_normals(SAMPLE_SEED, [first[part], second[part]], 3 * samples)
        noise[part] = blocks_times(root[part], normals.reshape(-1, 3, samples))
        noise[part] /= np.sqrt(weights[part])[:, None, None]
    return noise


def gauged(position: FloatArray, part: IntArray) -> FloatArray:
    """``position`` with each part's FLS of the smallest index at the origin.

    Relative measurements fix positions only up to a translation per part.

    Parameters
    ----------
    position : (N, 3) array of float, cm
    part : (N,) array of int
        Each FLS's connected part; -1 for an FLS in no measurement.

    Returns
    -------
    (N, 3) array of float, cm
        NaN for an FLS in no part.
    """
    out = np.full_like(position, np.nan)
    for one in np.unique(part[part >= 0]):
        members = np.flatnonzero(part == one)
        out[members] = position[members] - position[members[0]]
    return out
