"""The measurement graph a fit solves: measured vectors with their weights, and the robust loss.

The central fit (:mod:`.least_squares`) and the swarm's own (:mod:`.swarm_fit`) solve
the same weighted least-squares problem; what they share lives here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arrays import FloatArray, IntArray
from .hop_errors import hop_covariance, unbiased_vectors
from .sensor import Sensor

#: Huber's threshold on a measurement's Mahalanobis residual: the 99th percentile of a
#: chi distribution with 3 degrees of freedom, so a clean measurement is rarely down-weighted.
HUBER_THRESHOLD = 3.368
#: Then, from Huber's solution, a measurement beyond this Mahalanobis residual (the 99.9th
#: percentile) is rejected: weighed by REJECTED_WEIGHT, so far out of the fit that it
#: cannot bend it, while an FLS that nothing else measures keeps a position.
OUTLIER_THRESHOLD = 4.033
REJECTED_WEIGHT = 1e-6
#: Reweighting rounds of the robust fit, at most; it stops earlier once no
#: position moves by more than ``CONVERGED_CM``.
ROBUST_ROUNDS = 60
CONVERGED_CM = 1e-3


@dataclass(frozen=True)
class Measurements:
    """M measured hop vectors, each taken by FLS ``first`` of FLS ``second``."""

    first: IntArray  # (M,), the measuring FLS (swarm index)
    second: IntArray  # (M,), the measured FLS
    vectors: FloatArray  # (M, 3), cm, first -> second; a stochastic sensor's bias removed
    covariance: FloatArray  # (M, 3, 3), cm^2
    information: FloatArray  # (M, 3, 3), cm^-2: the covariance's inverse

    def __len__(self) -> int:
        return len(self.first)


def parts_of(size: int, measured: Measurements) -> IntArray:
    """Connected part of each FLS in the measurement graph.

    Parameters
    ----------
    size : int
        FLSs, N.
    measured : Measurements

    Returns
    -------
    (N,) array of int
        Parts numbered from 0; -1 for an FLS in no measurement.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements, parts_of
    >>> eye = np.broadcast_to(np.eye(3), (2, 3, 3))
    >>> measured = Measurements(np.array([0, 2]), np.array([1, 3]), np.ones((2, 3)), eye, eye)
    >>> parts_of(5, measured).tolist()
    [0, 0, 1, 1, -1]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix(
        (np.ones(len(measured)), (measured.first, measured.second)), shape=(size, size)
    )
    _, labels = connected_components(graph, directed=False)
    touched = np.zeros(size, dtype=bool)
    touched[measured.first] = touched[measured.second] = True
    _, part = np.unique(np.where(touched, labels, -1), return_inverse=True)
    part = part.astype(np.int64) - (0 if touched.all() else 1)
    return np.asarray(part, dtype=np.int64)


def robust_weights(measured: Measurements, positions: FloatArray, rejecting: bool) -> FloatArray:
    """The robust loss's weight (M,) of each measurement at ``positions`` (N, 3), cm.

    Huber's loss on the Mahalanobis residual (``HUBER_THRESHOLD``); once
    ``rejecting``, one or ``REJECTED_WEIGHT`` beyond ``OUTLIER_THRESHOLD``.

    Parameters
    ----------
    measured : Measurements
        M rows.
    positions : (N, 3) array of float, cm
        The fit's current positions.
    rejecting : bool
        Reject (the redescending step) instead of Huber's weights.

    Returns
    -------
    (M,) array of float
        In (0, 1].

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements, robust_weights
    >>> eye = np.broadcast_to(np.eye(3), (2, 3, 3))  # 1 cm^2 each way
    >>> measured = Measurements(np.array([0, 0]), np.array([1, 2]),
    ...                         np.array([[7.0, 0, 0], [0, 7, 0]]), eye, eye)
    >>> positions = np.array([[0.0, 0, 0], [7, 0, 0], [0, 7, 5]])  # FLS 2 is 5 cm off
    >>> robust_weights(measured, positions, rejecting=False).round(4)
    array([1.    , 0.6736])
    >>> robust_weights(measured, positions, rejecting=True)
    array([1.e+00, 1.e-06])
    """
    residual = positions[measured.second] - positions[measured.first] - measured.vectors
    distance = np.sqrt(np.einsum("ma,mab,mb->m", residual, measured.information, residual))
    if rejecting:
        weights = np.where(distance <= OUTLIER_THRESHOLD, 1.0, REJECTED_WEIGHT)
    else:
        weights = np.minimum(1.0, HUBER_THRESHOLD / np.maximum(distance, 1e-300))
    return np.asarray(weights, dtype=np.float64)


def measured_rows(
    sensor: Sensor,
    radius: float,
    first: IntArray,
    second: IntArray,
    raw: FloatArray,
    tracking: FloatArray,
) -> Measurements:
    """Measurements (M,) of the readings ``raw`` (M, 3), cm, of ``first`` of ``second``.

    The known bias comes off each vector and each gets its covariance and
    information at the pair's tracking distance ``tracking`` (M,), cm, along
    its measured direction (docs/core.md, "The least-squares fit").

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.
    first, second : (M,) array of int
        The measuring and the measured FLS.
    raw : (M, 3) array of float, cm
        The readings, first -> second.
    tracking : (M,) array of float, cm
        The pairs' tracking distances.

    Returns
    -------
    Measurements
    """
    directions = raw / np.linalg.norm(raw, axis=1, keepdims=True)
    return Measurements(
        first,
        second,
        unbiased_vectors(sensor, raw, tracking),
        hop_covariance(sensor, tracking, directions, radius),
        hop_covariance(sensor, tracking, directions, radius, inverse=True),
    )
