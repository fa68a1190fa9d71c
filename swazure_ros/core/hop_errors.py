"""What a sensor measures of a hop, and the error it is expected to add.

:func:`measured_vectors` measures hops with a :class:`~.sensor.Sensor`;
:func:`hop_error`, :func:`hop_covariance` and :func:`expected_error` predict
their errors (the least-error policy's costs, a fit's weights);
:func:`unbiased_vectors` takes a calibrated sensor's known bias out.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray
from .draws import standard_normals
from .geometry import centre_distance
from .sensor import Sensor


def _normal_plane(unit: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two unit vectors (M, 3) each, normal to ``unit`` (M, 3) and to each other."""
    helper = np.where(np.abs(unit[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    across = np.cross(unit, helper)
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    return across, np.cross(unit, across)


def measured_vectors(
    sensor: Sensor, points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> FloatArray:
    """Measured vectors first -> second: true direction, length t' + 2r (spec, section 3).

    A stochastic sensor adds the pair's own seeded draw to the length and the
    direction (the same draw wherever the pair is measured); a rendering
    camera measures the marker in a rendered frame.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array, cm
        FLS centres.
    radius : float, cm
        The FLS radius r.
    first, second : (M,) array_like of int
        The measuring FLS and the measured FLS.

    Returns
    -------
    (M, 3) array, cm
        NaN rows where a camera did not see the marker.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.hop_errors import measured_vectors
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [10, 0, 0]])  # t = 8 cm at r = 1, e(8) = 1.09 %
    >>> measured_vectors(published, points, 1.0, [0], [1]).round(4)
    array([[10.0875,  0.    ,  0.    ]])
    """
    first = np.asarray(first, dtype=np.int64)
    second = np.asarray(second, dtype=np.int64)
    offset = points[second] - points[first]
    distance = centre_distance(points, first, second)
    tracking = distance - 2.0 * radius
    unit = offset / distance[:, None]
    if sensor.camera is not None:
        # The rendering camera on i's surface aims at j; its frame's x, y, z are
        # (across, other, unit), and it measures the marker's centre on j's surface.
        across, other = _normal_plane(unit)
        centres = sensor.camera.measure_pairs(
            10.0 * tracking,
            sensor.camera_seed,
            first,
            second,
            markers=sensor.camera_markers,
        )
        length = np.linalg.norm(centres, axis=1, keepdims=True)
        seen = centres / length
        direction = seen[:, :1] * across + seen[:, 1:2] * other + seen[:, 2:3] * unit
        return np.asarray(direction * (length / 10.0 + 2.0 * radius), dtype=np.float64)
    measured = sensor.measured_tracking(tracking)
    noise = sensor.noise
    if noise is None:
        return np.asarray(
            offset * ((measured + 2.0 * radius) / distance)[:, None], dtype=np.float64
        )
    # A stochastic sensor: the pair's own draw (fixed by seed and pair) on the
    # length and on the direction, in the plane normal to the true direction.
    z = standard_normals(noise.seed, [first, second], 3)
    measured = measured + tracking * noise.at(noise.distance_sd, tracking) * z[:, 0]
    across, other = _normal_plane(unit)
    spread = np.radians(noise.at(noise.direction_sd_deg, tracking))[:, None]
    direction = unit + spread * (z[:, 1:2] * across + z[:, 2:3] * other)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return np.asarray(direction * (measured + 2.0 * radius)[:, None], dtype=np.float64)


def _hop_deviations(
    sensor: Sensor, tracking: FloatArray, radius: float
) -> tuple[FloatArray, FloatArray]:
    """Standard deviations (cm) of a hop vector's error along the hop and per axis across it.

    Stochastic sensor: the table's scatter of the length, ``t sd_d(t)``, and of
    the direction, ``(t' + 2r) sd_dir(t)`` (small angles). Deterministic
    sensor: its bias ``|t e(t)|`` along the hop and an exact direction.
    """
    noise = sensor.noise
    if noise is None:
        return np.abs(tracking * sensor.relative_error(tracking)), np.zeros_like(tracking)
    length = sensor.measured_tracking(tracking) + 2.0 * radius
    along = tracking * noise.at(noise.distance_sd, tracking)
    return along, length * np.radians(noise.at(noise.direction_sd_deg, tracking))


def hop_error(sensor: Sensor, tracking: ArrayLike, radius: float) -> FloatArray:
    """Expected error that a measured hop adds to a summed vector, per tracking distance (M,).

    The least-error path policy's edge cost (docs/core.md, "Least-error paths"):

    - a deterministic sensor (the published quadratic): the magnitude of the
      hop's length error, ``|t e(t)|``, cm;
    - a stochastic sensor: the variance of the hop vector's error, cm^2: the
      measured length's ``(t sd_d(t))^2`` plus the direction's two axes,
      ``2 ((t' + 2r) sd_dir(t))^2`` (small angles).

    Zero for an error-free sensor. A rendering camera has no model of its
    error but the polynomial its sensor file may give.

    Parameters
    ----------
    sensor : Sensor
    tracking : (M,) array_like of float, cm
        The hops' tracking distances.
    radius : float, cm
        The FLS radius r (the direction's error scales with t' + 2r).

    Returns
    -------
    (M,) array of float
        cm for a deterministic sensor, cm^2 for a stochastic one;
        :func:`expected_error` turns sums of them into cm.

    Examples
    --------
    >>> from swazure_ros.core.hop_errors import hop_error
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> hop_error(published, [6.0, 7.19, 15.0], 1.0).round(3)  # a 7 cm hop is cheapest
    array([0.092, 0.079, 1.641])
    """
    tracking = np.asarray(tracking, dtype=np.float64)
    along, across = _hop_deviations(sensor, tracking, radius)
    if sensor.noise is None:
        return np.asarray(along, dtype=np.float64)
    return np.asarray(along**2 + 2.0 * across**2, dtype=np.float64)


#: Relative standard deviation (a fraction of the hop's length) that every axis of a
#: hop's covariance has at least: what a model calls exact (the published sensor's
#: direction, a stochastic table's zero scatter) still gets a finite weight in a fit.
COVARIANCE_FLOOR = 1e-5


def unbiased_vectors(sensor: Sensor, vectors: FloatArray, tracking: ArrayLike) -> FloatArray:
    """Measured hop vectors (M, 3), cm, with a stochastic sensor's known bias taken out.

    A calibrated table's mean error e(t) is known: ``t e(t)`` comes off each
    vector's length. The published quadratic is treated as unknown, as the
    paper does: other sensors' vectors come back as they are.

    Parameters
    ----------
    sensor : Sensor
    vectors : (M, 3) array of float, cm
        Measured hop vectors (:func:`measured_vectors`).
    tracking : (M,) array_like of float, cm
        The pairs' true tracking distances, at which e(t) is taken.

    Returns
    -------
    (M, 3) array of float, cm
        ``vectors`` itself for a sensor without a noise table.
    """
    if sensor.noise is None:
        return vectors
    tracking = np.asarray(tracking, dtype=np.float64)
    length = np.linalg.norm(vectors, axis=1)
    corrected = length - tracking * sensor.relative_error(tracking)
    return np.asarray(vectors * (corrected / length)[:, None], dtype=np.float64)


def hop_covariance(
    sensor: Sensor,
    tracking: ArrayLike,
    directions: FloatArray,
    radius: float,
    inverse: bool = False,
) -> FloatArray:
    """Covariance, cm^2, of the error of hops of tracking distance ``tracking``.

    :func:`hop_error`'s two deviations, along the hop (unit ``directions``)
    and across it: ``along^2 u u^T + across^2 (I - u u^T)``; every axis at
    least ``COVARIANCE_FLOOR`` of the hop's length, so that what a model calls
    exact keeps a finite weight in a fit. Taken at the pair's tracking
    distance, as every expected error of the engine is.

    Parameters
    ----------
    sensor : Sensor
    tracking : (M,) array_like of float, cm
        The hops' tracking distances.
    directions : (M, 3) array of float
        The hops' unit directions.
    radius : float, cm
        The FLS radius r.
    inverse : bool, default False
        Give the information matrix (the inverse, cm^-2) instead, built from
        the same two axes: exact where a numerical inverse of a matrix whose
        axes differ by 1e10 is not.

    Returns
    -------
    (M, 3, 3) array of float
        cm^2, or cm^-2 with ``inverse``.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.hop_errors import hop_covariance
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> covariance = hop_covariance(published, [7.0], np.array([[1.0, 0, 0]]), 1.0)[0]
    >>> bool(covariance[0, 0] > 1e5 * covariance[1, 1])  # the bias along, an exact direction
    True
    """
    tracking = np.asarray(tracking, dtype=np.float64)
    along, across = _hop_deviations(sensor, tracking, radius)
    floor = (COVARIANCE_FLOOR * (tracking + 2.0 * radius)) ** 2
    along_var, across_var = along**2 + floor, across**2 + floor
    if inverse:
        along_var, across_var = 1.0 / along_var, 1.0 / across_var
    outer = directions[:, :, None] * directions[:, None, :]
    return np.asarray(
        (along_var - across_var)[:, None, None] * outer + across_var[:, None, None] * np.eye(3),
        dtype=np.float64,
    )


#: Points per cm at which :func:`smallest_hop_error` samples the camera's ranges.
_HOP_ERROR_SAMPLES_PER_CM = 1000
#: How far below the smallest sample :func:`smallest_hop_error` answers (a fraction).
_HOP_ERROR_MARGIN = 1e-2


def smallest_hop_error(sensor: Sensor, radius: float) -> float:
    """A lower bound of :func:`hop_error` over the camera's ranges, sweet_min to decaying_max.

    Sampled every 10 um and at the noise table's rows, then lowered by 1 %:
    both error models are smooth or piecewise linear between the samples, so
    no hop falls below it. Distributed least-error discovery sizes its cost
    buckets by it (protocol.discovery.buckets.bucket_width).

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.

    Returns
    -------
    float
        In :func:`hop_error`'s unit (cm or cm^2); 0 for an error-free sensor.

    Examples
    --------
    >>> from swazure_ros.core.hop_errors import smallest_hop_error
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> round(smallest_hop_error(published, 1.0), 4)  # 1 % under e's 0.079 cm at 7.19 cm
    0.0783
    """
    count = int((sensor.decaying_max - sensor.sweet_min) * _HOP_ERROR_SAMPLES_PER_CM) + 2
    samples = np.linspace(sensor.sweet_min, sensor.decaying_max, count)
    if sensor.noise is not None:
        table = np.asarray(sensor.noise.tracking_cm)
        inside = table[(table >= sensor.sweet_min) & (table <= sensor.decaying_max)]
        samples = np.concatenate([samples, inside])
    return float(hop_error(sensor, samples, radius).min() * (1.0 - _HOP_ERROR_MARGIN))


def expected_error(sensor: Sensor, summed: ArrayLike) -> FloatArray:
    """Predicted error (cm) of estimates whose hops' :func:`hop_error` sum to ``summed`` (M,).

    Stochastic sensor: the standard deviation of the summed vector's error,
    ``sqrt(summed)`` (independent hops' variances add). Deterministic sensor:
    ``summed`` itself, which bounds the error (triangle inequality).

    Parameters
    ----------
    sensor : Sensor
    summed : (M,) array_like of float
        Sums of :func:`hop_error` over each estimate's hops (cm, or cm^2 for a
        stochastic sensor).

    Returns
    -------
    (M,) array of float, cm
    """
    summed = np.asarray(summed, dtype=np.float64)
    return np.sqrt(summed) if sensor.noise is not None else summed
