"""What a receiver can check of a path label without trusting its sender.

The shape is common knowledge of a display: every FLS knows where every FLS
is assigned (and the world revision says where those that moved are). So a
label's path must be a chain of hops in the phase's ranges by those points,
its length and expected error must be the sums of its hops', and its summed
vector must lie within the sensor's error bounds of the true displacement
from the source to the sender. A label that fails is a forgery or a defect;
either way it must not reach an answer (docs/security.md). What cannot be
checked this way, a vector forged within the bounds, needs the swarm's key
(:mod:`swazure_ros.ros.auth`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..core.sensor import DECAYING, SWEET, Sensor, hop_error
from .discovery import ANY_VISIBLE, Offer

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Standard deviations of a stochastic sensor's hop error that a plausible hop stays within.
NOISE_BOUND_SD = 8.0
#: Relative tolerance on sums that sender and receiver add in different orders.
SUM_TOLERANCE = 1e-6


def hop_bound(sensor: Sensor, tracking: FloatArray, radius: float) -> FloatArray:
    """The largest error (cm) that a measured hop of tracking distance ``tracking`` (M,) may carry.

    The published quadratic's length error exactly; a stochastic sensor's bias
    plus :data:`NOISE_BOUND_SD` standard deviations; a rendering camera, which
    has no error model, anything within the hop's own length.
    """
    if sensor.camera is not None:
        return np.asarray(tracking + 2.0 * radius, dtype=np.float64)
    bias = np.abs(tracking * sensor.relative_error(tracking))
    if sensor.noise is None:
        return np.asarray(bias, dtype=np.float64)
    return np.asarray(bias + NOISE_BOUND_SD * np.sqrt(hop_error(sensor, tracking, radius)))


def implausible(
    offer: Offer,
    phase: int,
    positions: Callable[[IntArray], FloatArray],
    sensor: Sensor,
    radius: float,
) -> str | None:
    """Why the labels of ``offer`` cannot be true, or None when every one may be.

    ``positions(ids)`` gives where FLSs ``ids`` (M,) are, (M, 3), cm; the
    offer's arrays are already known to agree (:func:`..ros.convert.offer_from_message`).
    """
    if not len(offer):
        return None
    path_ids, offsets = offer.path_ids, offer.path_offsets
    points = positions(path_ids)
    # Hop k of the flat path list runs from path_ids[k] to path_ids[k + 1], unless
    # k + 1 starts the next path.
    offset = points[1:] - points[:-1]
    step = np.sqrt(np.einsum("...k,...k->...", offset, offset))  # as core.geometry rounds it
    real = np.ones(len(step), dtype=bool)
    real[offsets[1:-1] - 1] = False
    tracking = np.where(real, step - 2.0 * radius, 0.0)
    allowed = (SWEET, DECAYING) if phase == ANY_VISIBLE else (SWEET,)
    if not np.isin(sensor.classify(tracking[real]), allowed).all():
        return "a hop of a path is not in range"

    # Per label, the sum over its hops: positions offsets[k] .. offsets[k + 1] - 2.
    def per_label(values: FloatArray) -> FloatArray:
        summed = np.concatenate([[0.0], np.cumsum(np.where(real, values, 0.0))])
        return np.asarray(summed[offsets[1:] - 1] - summed[offsets[:-1]])

    length = per_label(tracking)
    if not np.allclose(offer.lengths, length, rtol=SUM_TOLERANCE, atol=SUM_TOLERANCE):
        return "a length is not its path's"
    error = per_label(hop_error(sensor, tracking, radius))
    if not np.allclose(offer.errors, error, rtol=SUM_TOLERANCE, atol=SUM_TOLERANCE):
        return "an expected error is not its path's"
    bound = per_label(hop_bound(sensor, tracking, radius))
    start, end = points[offsets[:-1]], points[offsets[1:] - 1]
    off = np.linalg.norm(offer.vectors - (end - start), axis=1)
    measured = ~np.isnan(off)  # S_all labels sum no camera readings
    if (off[measured] > bound[measured] * (1.0 + SUM_TOLERANCE) + SUM_TOLERANCE).any():
        return "a vector is beyond the sensor's error bounds"
    return None
