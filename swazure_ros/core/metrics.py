"""Error metrics of relative-pose estimates (spec, section 6). Angles in degrees."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import ArrayLike

from .arrays import FloatArray


def _vectors(name: str, value: ArrayLike) -> FloatArray:
    array = np.asarray(value, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"Expected `{name}` to have shape (M, 3), got {array.shape}")
    return array


def distance_error_pct(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Distance error | |estimate| - |truth| | / |truth| * 100, percent (spec, section 6).

    100 % is an estimate twice as long as the truth, or of length zero.

    Parameters
    ----------
    estimate : (M, 3) array_like of float, cm
        Estimated relative positions (any unit, the truth's: the errors are
        ratios and angles).
    truth : (M, 3) array_like of float, cm
        The true relative positions, non-zero.

    Returns
    -------
    (M,) array of float, percent

    Raises
    ------
    ValueError
        An argument is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import distance_error_pct
    >>> distance_error_pct([[11.0, 0, 0], [0, 10, 0]], [[10.0, 0, 0], [10, 0, 0]])
    array([10.,  0.])
    """
    estimate, truth = _vectors("estimate", estimate), _vectors("truth", truth)
    size = np.linalg.norm(truth, axis=1)
    return np.asarray(np.abs(np.linalg.norm(estimate, axis=1) - size) / size * 100.0)


def alpha_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Alpha: the angle between estimate and truth, atan2(|a x b|, a . b), degrees.

    atan2 rather than acos of the cosine: accurate for small angles too.

    Parameters
    ----------
    estimate : (M, 3) array_like of float, cm
        Estimated relative positions (any unit, the truth's: the errors are
        ratios and angles).
    truth : (M, 3) array_like of float, cm
        The true relative positions, non-zero.

    Returns
    -------
    (M,) array of float, degrees in [0, 180]

    Raises
    ------
    ValueError
        An argument is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import alpha_deg
    >>> alpha_deg([[11.0, 0, 0], [0, 10, 0]], [[10.0, 0, 0], [10, 0, 0]])
    array([ 0., 90.])
    """
    estimate, truth = _vectors("estimate", estimate), _vectors("truth", truth)
    cross = np.linalg.norm(np.cross(estimate, truth), axis=1)
    dot = np.einsum("ij,ij->i", estimate, truth)
    return np.asarray(np.degrees(np.arctan2(cross, dot)))


def inclination_deg(vectors: ArrayLike) -> FloatArray:
    """Inclination theta = acos(z / |v|) of each vector, degrees.

    Parameters
    ----------
    vectors : (M, 3) array_like of float, cm
        Non-zero.

    Returns
    -------
    (M,) array of float, degrees in [0, 180]

    Raises
    ------
    ValueError
        ``vectors`` is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import inclination_deg
    >>> inclination_deg([[0, 0, 1], [1, 0, 0]])
    array([ 0., 90.])
    """
    vectors = _vectors("vectors", vectors)
    cosine = vectors[:, 2] / np.linalg.norm(vectors, axis=1)
    return np.asarray(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def azimuth_deg(vectors: ArrayLike) -> FloatArray:
    """Azimuth phi = atan2(y, x) of each vector, degrees.

    Parameters
    ----------
    vectors : (M, 3) array_like of float, cm
        Non-zero.

    Returns
    -------
    (M,) array of float, degrees in (-180, 180]

    Raises
    ------
    ValueError
        ``vectors`` is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import azimuth_deg
    >>> azimuth_deg([[0, 1, 0], [-1, 0, 0]])
    array([ 90., 180.])
    """
    vectors = _vectors("vectors", vectors)
    return np.asarray(np.degrees(np.arctan2(vectors[:, 1], vectors[:, 0])))


def theta_error_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Theta error |theta_hat - theta|: the error of the inclination, degrees.

    Parameters
    ----------
    estimate : (M, 3) array_like of float, cm
        Estimated relative positions (any unit, the truth's: the errors are
        ratios and angles).
    truth : (M, 3) array_like of float, cm
        The true relative positions, non-zero.

    Returns
    -------
    (M,) array of float, degrees in [0, 180]

    Raises
    ------
    ValueError
        An argument is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import theta_error_deg
    >>> theta_error_deg([[1.0, 0, 1]], [[1.0, 0, 0]])
    array([45.])
    """
    return np.asarray(np.abs(inclination_deg(estimate) - inclination_deg(truth)))


def phi_error_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Phi error min(d, 360 - d) with d = |phi_hat - phi|: the azimuth's error, degrees.

    Near the z axis a small error of the vector turns the azimuth a lot.

    Parameters
    ----------
    estimate : (M, 3) array_like of float, cm
        Estimated relative positions (any unit, the truth's: the errors are
        ratios and angles).
    truth : (M, 3) array_like of float, cm
        The true relative positions, non-zero.

    Returns
    -------
    (M,) array of float, degrees in [0, 180]

    Raises
    ------
    ValueError
        An argument is not of shape (M, 3).

    Examples
    --------
    >>> from swazure_ros.core.metrics import phi_error_deg
    >>> phi_error_deg([[-1.0, -0.01, 0]], [[-1.0, 0.01, 0]])  # across the -x axis
    array([1.1458774])
    """
    difference = np.abs(azimuth_deg(estimate) - azimuth_deg(truth))
    return np.asarray(np.minimum(difference, 360.0 - difference))


def pose_errors(
    estimate: ArrayLike, truth: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Distance error (%), alpha, theta and phi errors (deg) of each estimate.

    NaN where an estimate is NaN (a pair without a path), without a warning.

    Parameters
    ----------
    estimate : (M, 3) array_like of float, cm
        Estimated relative positions (any unit, the truth's: the errors are
        ratios and angles).
    truth : (M, 3) array_like of float, cm
        The true relative positions, non-zero.

    Returns
    -------
    distance_error : (M,) array of float, percent
    alpha, theta, phi : (M,) array of float, degrees
        :func:`alpha_deg`, :func:`theta_error_deg`, :func:`phi_error_deg`.

    Raises
    ------
    ValueError
        An argument is not of shape (M, 3).

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.metrics import pose_errors
    >>> distance, alpha, theta, phi = pose_errors([[np.nan] * 3, [11.0, 0, 0]], [[10.0, 0, 0]] * 2)
    >>> distance
    array([nan, 10.])
    """
    with np.errstate(invalid="ignore"):
        return (
            distance_error_pct(estimate, truth),
            alpha_deg(estimate, truth),
            theta_error_deg(estimate, truth),
            phi_error_deg(estimate, truth),
        )


@dataclass(frozen=True)
class Stats:
    """Mean, max and quantiles of some values, in their unit; None when there are none."""

    mean: float | None
    max: float | None
    p50: float | None
    p90: float | None
    p99: float | None
    count: int

    def as_document(self) -> dict[str, float | None]:
        """The JSON object summary.json holds for these statistics."""
        return asdict(self)


#: The statistics of no values.
NO_VALUES = Stats(None, None, None, None, None, 0)


def describe(values: ArrayLike) -> Stats:
    """Mean, max and quantiles of ``values`` as plain floats (None when empty).

    Parameters
    ----------
    values : (M,) array_like of float
        In any unit; no NaN (leave out the pairs without a value first).

    Returns
    -------
    Stats
        Mean, max, the 50th, 90th and 99th percentiles (numpy's linear
        interpolation) and the count; :data:`NO_VALUES` for no values.

    Examples
    --------
    >>> from swazure_ros.core.metrics import describe
    >>> stats = describe([1.0, 2.0, 3.0, 4.0])
    >>> stats.mean, stats.max, stats.p90, stats.count
    (2.5, 4.0, 3.7, 4)
    >>> describe([]).mean is None
    True
    """
    values = np.asarray(values, dtype=np.float64)
    if len(values) == 0:
        return NO_VALUES
    p50, p90, p99 = np.percentile(values, [50, 90, 99])
    return Stats(
        mean=float(values.mean()),
        max=float(values.max()),
        p50=float(p50),
        p90=float(p90),
        p99=float(p99),
        count=len(values),
    )
