"""What a receiver can check of a path label without trusting its sender.

The shape is common knowledge of a display: every FLS knows where every FLS
is assigned (and the world revision says where those that moved are). So a
label's path must be a chain of hops in the phase's ranges by those points,
its length and expected error must be the sums of its hops', and its summed
vector must lie within the sensor's error bounds of the true displacement
from the source to the sender. A label that fails is a forgery or a defect;
either way it must not reach an answer (docs/security.md). What cannot be
checked this way, a vector forged within the bounds, needs the swarm's key
(:mod:`swazure_ros.ros.security.auth`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..core import csr
from ..core.arrays import FloatArray, IdArray, IntArray
from ..core.fit import PATH, SWARM_ESTIMATORS
from ..core.geometry import centre_distance
from ..core.hop_errors import hop_error
from ..core.sensor import DECAYING, SWEET, Sensor
from .discovery.estimate import Estimates
from .discovery.messages import ANY_VISIBLE, Offer, RoundOffers
from .readings import Readings

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


#: Why a label cannot be true, by the code :func:`implausible_labels` gives it (0: it may be).
REASONS = (
    "",
    "a hop of a path is not in range",
    "a length is not its path's",
    "an expected error is not its path's",
    "a vector is beyond the sensor's error bounds",
)
_HOP, _LENGTH, _ERROR, _VECTOR = 1, 2, 3, 4


def implausible_labels(
    lengths: FloatArray | None,
    errors: FloatArray | None,
    vectors: FloatArray,
    path_offsets: IntArray,
    path_ids: IdArray,
    phase: int,
    positions: Callable[[IntArray], FloatArray],
    sensor: Sensor,
    radius: float,
) -> NDArray[np.int8]:
    """(L,) why each of L labels cannot be true (a code of :data:`REASONS`; 0: it may be).

    The labels are an offer's or a round's (lengths, errors (L,), vectors
    (L, 3), cm, paths as offsets (L + 1,) into ``path_ids``), whose arrays
    are known to agree (:func:`..ros.convert.offers.offer_from_message`).
    ``positions(ids)`` gives where FLSs ``ids`` (M,) are, (M, 3), cm.
    Without ``lengths`` or ``errors`` (a report's), those sums are not checked.
    """
    count = len(path_offsets) - 1
    why = np.zeros(count, dtype=np.int8)
    if not count:
        return why
    points = positions(path_ids.astype(np.int64, copy=False))  # uint32 as offers carry them
    # Hop k of the flat path list runs from path_ids[k] to path_ids[k + 1], unless k + 1
    # starts the next path. The last place has no hop: every label's hops then lie in its
    # own places, offsets[l] .. offsets[l + 1] - 1, its last one not a hop (held at 0).
    places = np.arange(len(points), dtype=np.int64)
    tracking = np.zeros(len(points), dtype=np.float64)
    np.subtract(centre_distance(points, places[:-1], places[1:]), 2.0 * radius, out=tracking[:-1])
    not_hops = path_offsets[1:] - 1
    tracking[not_hops] = 0.0
    classes = sensor.classify(tracking)
    in_range = classes == SWEET
    if phase == ANY_VISIBLE:
        in_range |= classes == DECAYING
    in_range[not_hops] = True
    out = np.flatnonzero(~in_range)  # few, or none: labels are mostly true
    why[np.searchsorted(path_offsets, out, "right") - 1] = _HOP
    hop_errors = hop_error(sensor, tracking, radius)
    # The published sensor's bound is its hop error itself (|t e(t)|).
    exact = sensor.noise is None and sensor.camera is None
    bounds = hop_errors if exact else hop_bound(sensor, tracking, radius)
    bounds[not_hops] = 0.0  # a camera's bound is not 0 at a tracking distance of 0
    hop_errors[not_hops] = 0.0
    starts = path_offsets[:-1]

    def mark(wrong: NDArray[np.bool_], code: int) -> None:
        why[(why == 0) & wrong] = code

    if lengths is not None:
        mark(~_close(lengths, _per_label(tracking, starts)), _LENGTH)
    if errors is not None:
        mark(~_close(errors, _per_label(hop_errors, starts)), _ERROR)
    start, end = np.take(points, starts, axis=0), np.take(points, not_hops, axis=0)
    miss = vectors - (end - start)
    off = np.sqrt(np.einsum("...k,...k->...", miss, miss))
    # NaN (an S_all label sums no camera readings) compares False: it may be.
    bound = _per_label(bounds, starts)
    mark(off > bound * (1.0 + SUM_TOLERANCE) + SUM_TOLERANCE, _VECTOR)
    return why


def _per_label(values: FloatArray, starts: IntArray) -> FloatArray:
    """(L,) the sums of ``values`` (P,) over each label's places, from ``starts`` (L,) (every
    path at least one place) to the next label's start, each summed in order."""
    return np.asarray(np.add.reduceat(values, starts), dtype=np.float64)


def implausible(
    offer: Offer,
    phase: int,
    positions: Callable[[IntArray], FloatArray],
    sensor: Sensor,
    radius: float,
) -> str | None:
    """Why the labels of ``offer`` cannot all be true, or None when every one may be."""
    why = implausible_labels(
        offer.lengths,
        offer.errors,
        offer.vectors,
        offer.path_offsets,
        offer.path_ids,
        phase,
        positions,
        sensor,
        radius,
    )
    return REASONS[int(why.max())] if why.any() else None


def implausible_estimates(
    estimates: Estimates,
    source: int,
    positions: Callable[[IntArray], FloatArray],
    sensor: Sensor,
    radius: float,
) -> str | None:
    """Why a source's report cannot be true, or None when every estimate of it may be.

    Each path must run from the source to its target; a path estimate's
    (a vector summed along its path) hops must be in range (sweet or
    decaying) and its vector within the sensor's error bounds of the true
    displacement, as an offer's label's. A fit's vector is not a path's sum:
    only its path is checked.
    """
    has_path = np.diff(estimates.path_offsets) > 0
    if not has_path.any():
        return None
    firsts = estimates.path_ids[estimates.path_offsets[:-1][has_path]]
    lasts = estimates.path_ids[estimates.path_offsets[1:][has_path] - 1]
    if (firsts != source).any() or (lasts != estimates.targets[has_path]).any():
        return "a path does not run from its source to its target"
    summed = np.flatnonzero(has_path & (estimates.estimator == SWARM_ESTIMATORS.index(PATH)))
    offsets, path_ids = csr.take(estimates.path_offsets, estimates.path_ids, summed)
    why = implausible_labels(
        None,
        None,
        estimates.vector[summed],
        offsets,
        path_ids,
        ANY_VISIBLE,
        positions,
        sensor,
        radius,
    )
    return REASONS[int(why.max())] if why.any() else None


def implausible_readings(
    readings: Readings,
    positions: Callable[[IntArray], FloatArray],
    sensor: Sensor,
    radius: float,
) -> str | None:
    """Why an FLS's camera readings cannot all be true, or None when every one may be.

    By the shape, as a label's hops: each pair's radio distance is its
    tracking distance, its range class that distance's, and its vector
    within the sensor's error bounds of the displacement.
    """
    if not len(readings.other):
        return None
    points = positions(np.append(readings.other, readings.owner))
    offset = points[:-1] - points[-1]
    tracking = np.sqrt(np.einsum("...k,...k->...", offset, offset)) - 2.0 * radius
    if not _close(readings.distance, tracking).all():
        return "a radio distance is not the pair's"
    if not np.array_equal(sensor.classify(tracking), readings.range_class):
        return "a range class is not the pair's"
    if _beyond_bounds(readings.vector, offset, tracking, sensor, radius):
        return "a vector is beyond the sensor's error bounds"
    return None


def offer_readings_check(
    positions: Callable[[IntArray], FloatArray], sensor: Sensor, radius: float
) -> Callable[[int, Offer], str | None]:
    """A radio's check of the readings an offer carries (RadioHub's ``check_readings``)."""

    def check(sender: int, offer: Offer) -> str | None:
        points = positions(np.append(offer.reading_ids, sender))
        offset = points[:-1] - points[-1]
        tracking = np.sqrt(np.einsum("...k,...k->...", offset, offset)) - 2.0 * radius
        classes = sensor.classify(tracking)
        if not np.isin(classes, (SWEET, DECAYING)).all():
            return "a reading is not in camera range"
        if _beyond_bounds(offer.reading_vectors, offset, tracking, sensor, radius):
            return "a reading is beyond the sensor's error bounds"
        return None

    return check


def _beyond_bounds(
    vectors: FloatArray, offset: FloatArray, tracking: FloatArray, sensor: Sensor, radius: float
) -> bool:
    """True when a measured vector (K, 3) is beyond the sensor's bounds of its displacement."""
    exact = sensor.noise is None and sensor.camera is None
    bound = hop_error(sensor, tracking, radius) if exact else hop_bound(sensor, tracking, radius)
    miss = vectors - offset
    off = np.sqrt(np.einsum("...k,...k->...", miss, miss))
    return bool((off > bound * (1.0 + SUM_TOLERANCE) + SUM_TOLERANCE).any())


def round_labels_check(
    positions: Callable[[IntArray], FloatArray], sensor: Sensor, radius: float
) -> Callable[[RoundOffers, int], NDArray[np.int8]]:
    """A radio's check of a round's offers (RadioHub's ``check``): each label's code."""

    def check(heard: RoundOffers, phase: int) -> NDArray[np.int8]:
        return implausible_labels(
            heard.lengths,
            heard.errors,
            heard.vectors,
            heard.path_offsets,
            heard.path_ids,
            phase,
            positions,
            sensor,
            radius,
        )

    return check


def _close(sent: FloatArray, summed: FloatArray) -> NDArray[np.bool_]:
    """Sums that sender and receiver add in different orders agree to SUM_TOLERANCE."""
    return np.asarray(np.abs(sent - summed) <= SUM_TOLERANCE * (1.0 + np.abs(summed)))
