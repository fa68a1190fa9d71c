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
    """| |estimate| - |truth| | / |truth| * 100 for (M, 3) vectors: (M,), percent."""
    estimate, truth = _vectors("estimate", estimate), _vectors("truth", truth)
    size = np.linalg.norm(truth, axis=1)
    return np.asarray(np.abs(np.linalg.norm(estimate, axis=1) - size) / size * 100.0)


def alpha_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """Angle between estimate and truth, atan2(|a x b|, a . b): (M,), degrees."""
    estimate, truth = _vectors("estimate", estimate), _vectors("truth", truth)
    cross = np.linalg.norm(np.cross(estimate, truth), axis=1)
    dot = np.einsum("ij,ij->i", estimate, truth)
    return np.asarray(np.degrees(np.arctan2(cross, dot)))


def inclination_deg(vectors: ArrayLike) -> FloatArray:
    """theta = acos(z / |v|) of (M, 3) vectors: (M,), degrees in [0, 180]."""
    vectors = _vectors("vectors", vectors)
    cosine = vectors[:, 2] / np.linalg.norm(vectors, axis=1)
    return np.asarray(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def azimuth_deg(vectors: ArrayLike) -> FloatArray:
    """phi = atan2(y, x) of (M, 3) vectors: (M,), degrees in (-180, 180]."""
    vectors = _vectors("vectors", vectors)
    return np.asarray(np.degrees(np.arctan2(vectors[:, 1], vectors[:, 0])))


def theta_error_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """|theta_hat - theta|: (M,), degrees."""
    return np.asarray(np.abs(inclination_deg(estimate) - inclination_deg(truth)))


def phi_error_deg(estimate: ArrayLike, truth: ArrayLike) -> FloatArray:
    """min(d, 360 - d) with d = |phi_hat - phi|: (M,), degrees in [0, 180]."""
    difference = np.abs(azimuth_deg(estimate) - azimuth_deg(truth))
    return np.asarray(np.minimum(difference, 360.0 - difference))


def pose_errors(
    estimate: ArrayLike, truth: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Distance error (%), alpha, theta and phi errors (deg) of each estimate: (M,) each.

    NaN where an estimate is NaN (a pair without a path).
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
    """Mean, max and quantiles of ``values`` as plain floats (None when empty)."""
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
