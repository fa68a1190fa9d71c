"""An FLS's radio offer of one round: PathOffer messages, their fields and their labels.

The messages a round brings most of: an offer from every FLS heard, and one
from each FLS a process hosts. The radio writes and reads them as bytes
(:mod:`..security.records`); :func:`offer_fields` is what both the bytes and
:func:`offer_message`'s object are made of.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from swazure_interfaces.msg import PathOffer

from ...core.arrays import FloatArray, IdArray, IntArray
from ...protocol.discovery.messages import FIT, SWEET_ALL, Broadcast, FitOffer, Offer
from ..plumbing.names import node_name
from ..security.guard import check, check_finite, check_ids, check_size
from ..security.records import Fields
from .discovery import FIT_VALUES, RUN_PHASES, checked_offsets
from .units import message_of

__all__ = ["offer_fields", "offer_from_message", "offer_message"]


def offer_fields(sent: Broadcast, stamp: Time) -> Fields:
    """One FLS's labels of one round: a PathOffer's fields by name (:mod:`..security.records`)."""
    offer, sender = sent.offer, sent.sender
    fields: dict[str, Any] = {
        "header.stamp.sec": stamp.sec,
        "header.stamp.nanosec": stamp.nanosec,
        "header.frame_id": node_name(sender),
        "run_id": sent.run_id,
        "phase": sent.phase,
        "round": sent.round,
        "sender_id": sender,
        "pending": offer.pending,
        "finished": offer.finished,
        "source_ids": offer.source_ids,
        "hops": offer.hops,
        "lengths": offer.lengths,
        "errors": offer.errors,
        "vectors": offer.vectors,
        "path_offsets": offer.path_offsets,
        "path_ids": offer.path_ids,
        "reading_ids": offer.reading_ids,
        "reading_vectors": offer.reading_vectors,
        "fit_label": -1 if offer.fit is None else offer.fit.label,
    }
    if offer.unbiased is not None and offer.covariances is not None:
        fields["unbiased_vectors"] = offer.unbiased
        fields["covariances"] = offer.covariances
    if offer.fit is not None:
        fields["fit_values"] = offer.fit.values
    return fields


def offer_message(sent: Broadcast, stamp: Time) -> PathOffer:
    """One FLS's labels of one round as a PathOffer message (:func:`offer_fields`)."""
    message: PathOffer = message_of(PathOffer, offer_fields(sent, stamp))
    return message


def offer_from_message(message: PathOffer, swarm: IntArray) -> Offer:
    """The labels of a PathOffer message from an FLS of ``swarm`` (sorted ids).

    MessageError unless its arrays agree in length, every id is in the swarm,
    every path runs from its label's source to the sender with ``hops`` hops,
    and costs are finite and not negative (vectors may be NaN only in the
    S_all phase, whose hops need no camera reading).
    """
    check(message.phase in RUN_PHASES, f"unknown phase {message.phase}")
    count = len(message.source_ids)
    check_size(message.source_ids, len(swarm), "source_ids")
    check(
        len(message.hops) == count == len(message.lengths) == len(message.errors),
        "source_ids, hops, lengths and errors differ in length",
    )
    check(len(message.vectors) == 3 * count, "not 3 vector values per label")
    fits = len(message.unbiased_vectors) > 0 or len(message.covariances) > 0
    check_size(message.reading_ids, len(swarm), "reading_ids")
    check(len(message.reading_vectors) == 3 * len(message.reading_ids), "not 3 values a reading")
    reading_ids, reading_vectors = _NO_IDS, _NO_VECTORS  # most offers carry no readings
    if len(message.reading_ids):
        reading_ids = check_ids(message.reading_ids, swarm, "reading_ids")
        check(len(np.unique(reading_ids)) == len(reading_ids), "an FLS read twice")
        reading_vectors = check_finite(message.reading_vectors, "reading_vectors").reshape(-1, 3)
    check(
        not fits
        or (len(message.unbiased_vectors) == 3 * count and len(message.covariances) == 9 * count),
        "not 3 unbiased vector and 9 covariance values per label",
    )
    offsets = checked_offsets(
        message.path_offsets, message.path_ids, count, len(swarm), "path", "labels"
    )
    if count:
        sources, hops, lengths, errors, vectors, path_ids = _labels(message, offsets, swarm)
    else:  # a FIT round's offer, or a sender with nothing due: its sender is all to check
        check_ids([message.sender_id], swarm, "offer")
        sources, hops, path_ids = _NO_IDS, _NO_IDS, _NO_PATH_IDS
        lengths, errors, vectors = _NO_VALUES, _NO_VALUES, _NO_VECTORS
    return Offer(
        source_ids=sources,
        hops=hops,
        lengths=lengths,
        errors=errors,
        vectors=vectors,
        path_offsets=offsets,
        path_ids=path_ids,
        pending=message.pending,
        finished=message.finished,
        unbiased=_fit_sums(message, "unbiased_vectors", (-1, 3)) if fits else None,
        covariances=_fit_sums(message, "covariances", (-1, 3, 3)) if fits else None,
        reading_ids=reading_ids,
        reading_vectors=reading_vectors,
        fit=_fit_from_message(message, swarm) if message.phase == FIT else None,
    )


#: An offer's arrays when it has no label or no reading (read-only: shared by every offer).
_NO_IDS = np.zeros(0, dtype=np.int64)
_NO_PATH_IDS = np.zeros(0, dtype=np.uint32)
_NO_VALUES = np.zeros(0, dtype=np.float64)
_NO_VECTORS = np.zeros((0, 3), dtype=np.float64)
for _empty in (_NO_IDS, _NO_PATH_IDS, _NO_VALUES, _NO_VECTORS):
    _empty.flags.writeable = False


def _labels(
    message: PathOffer, offsets: IntArray, swarm: IntArray
) -> tuple[IntArray, IntArray, FloatArray, FloatArray, FloatArray, IdArray]:
    """An offer's labels, checked (:func:`offer_from_message`): sources, hops, lengths,
    errors, vectors (K, 3) and path ids."""
    sources = np.asarray(message.source_ids, dtype=np.int64)
    # A sender offers its labels in source order, one a source (PathSearch.offer).
    check(bool((sources[1:] > sources[:-1]).all()), "sources not in increasing order, once each")
    hops = np.asarray(message.hops, dtype=np.int64)
    lengths = check_finite(message.lengths, "lengths")
    errors = check_finite(message.errors, "errors")
    check(bool((lengths >= 0).all() and (errors >= 0).all()), "a negative cost")
    vectors = check_finite(message.vectors, "vectors", allow_nan=message.phase == SWEET_ALL)
    check(bool((np.diff(offsets) == hops + 1).all()), "a path is not hops + 1 FLSs long")
    path_ids = np.asarray(message.path_ids, dtype=np.uint32)  # as the wire's, as offers_of's
    # One look-up for every id: the sender's, and those of the paths (sources included).
    check_ids(np.append(path_ids, message.sender_id), swarm, "offer")
    starts, ends = path_ids[offsets[:-1]], path_ids[offsets[1:] - 1]
    check(bool((starts == sources).all()), "a path does not start at its source")
    check(bool((ends == message.sender_id).all()), "a path does not end at the sender")
    return sources, hops, lengths, errors, vectors.reshape(-1, 3), path_ids


def _fit_from_message(message: PathOffer, swarm: IntArray) -> FitOffer:
    """The FIT phase's part of a PathOffer: a label of the swarm (or -1) and finite values."""
    label = int(message.fit_label)
    if label != -1:
        check_ids([label], swarm, "fit_label")
    check_size(message.fit_values, FIT_VALUES, "fit_values")
    check(len(message.fit_values) % 3 == 0, "not 3 fit values a column")
    return FitOffer(label=label, values=check_finite(message.fit_values, "fit_values"))


def _fit_sums(message: PathOffer, name: str, shape: tuple[int, ...]) -> FloatArray:
    """A fitting offer's sums of field ``name``, shaped (NaN only where vectors may be)."""
    values = check_finite(getattr(message, name), name, allow_nan=message.phase == SWEET_ALL)
    return values.reshape(shape)
