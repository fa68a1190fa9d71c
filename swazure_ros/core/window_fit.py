"""A source's own fit: the readings it hears by radio in its window, and the fit over them.

The window of a source is itself and the FLSs in its radio range; the
readings are those its window's FLSs publish of each other
(:func:`heard_in_window`, as a :class:`Heard` table). :func:`window_fit`
fits them as the whole swarm's fit would, with the source as the origin:
the local-least-squares estimator, which an FLS's node runs as the engine does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from . import csr
from .arrays import FloatArray, IntArray
from .fit_measurements import fit_layers, joining, select_rows
from .least_squares import solve
from .measurement_graph import (
    measured_rows,
)
from .observe import Observations
from .sensor import (
    BLIND,
    SWEET,
    Sensor,
)


@dataclass(frozen=True)
class Heard:
    """What one source hears: the readings its window's FLSs publish, one row per reading.

    The rows an FLS gets from its radio neighbours' measurements (and its
    own): who measured whom, the range class and tracking distance of the
    pair (ranging by radio, cm) and the measured vector (cm). FLS ids, not
    swarm indices: the same table whether the engine lays it out or a node
    gathers it from messages.
    """

    owner: IntArray  # (R,), the measuring FLS
    other: IntArray  # (R,), the measured FLS
    range_class: NDArray[np.int8]  # (R,), SWEET or DECAYING
    tracking: FloatArray  # (R,), the pair's tracking distance, cm
    vector: FloatArray  # (R, 3), measured vector owner -> other, cm


def heard_in_window(seen: Observations, ids: IntArray, source: int) -> tuple[IntArray, Heard]:
    """The window of the FLS at swarm index ``source`` and the readings it hears there.

    The window is the source and the FLSs within its radio range (its blind
    and sweet neighbours; spec, section 4), as FLS ids, the source first;
    the readings are those of window FLSs of other window FLSs.
    """
    mine = seen.rows(source)
    radio = np.isin(seen.range_class[mine], (BLIND, SWEET))
    members = np.concatenate([[source], seen.other[mine][radio]]).astype(np.int64)
    starts, ends = seen.indptr[members], seen.indptr[members + 1]
    rows = csr.ragged_indices(starts, ends - starts)  # each member's rows, one after another
    owner = np.repeat(members, ends - starts)
    inside = np.zeros(len(ids), dtype=bool)
    inside[members] = True
    keep = seen.measured[rows] & inside[seen.other[rows]]
    rows, owner = rows[keep], owner[keep]
    heard = Heard(
        ids[owner],
        ids[seen.other[rows]],
        seen.range_class[rows],
        seen.distance[rows],
        seen.vector[rows],
    )
    return ids[members], heard


def window_fit(
    sensor: Sensor,
    radius: float,
    window: IntArray,
    heard: Heard,
    targets: IntArray,
    sweet: NDArray[np.bool_],
    robust: bool = True,
) -> tuple[FloatArray, FloatArray, int]:
    """A source's own fit of ``targets`` (K,) from what it hears (docs/core.md, "Own fit").

    ``window`` (W,) are FLS ids, the source first; ``heard`` the readings
    between them. The rows are chosen as :func:`fit_pairs` chooses them,
    over the window's own sweet graph, and a deterministic sensor gets the
    same two fits as :func:`fit_pairs_estimates`; ``sweet`` (K,) marks the
    targets with a sweet path. The source is the origin. Rows are taken in
    (owner, other) order, so that a node and the engine sum in one order.
    Returns the estimates (K, 3), cm, their covariances (K, 3, 3), cm^2,
    nan where the window does not join a target to the source, and the rows used.
    """
    order = np.lexsort((heard.other, heard.owner))
    lookup = {int(fls): slot for slot, fls in enumerate(window.tolist())}
    first = np.array([lookup[int(f)] for f in heard.owner[order]], dtype=np.int64)
    second = np.array([lookup[int(f)] for f in heard.other[order]], dtype=np.int64)
    measured = measured_rows(
        sensor, radius, first, second, heard.vector[order], heard.tracking[order]
    )
    is_sweet = heard.range_class[order] == SWEET
    size = len(window)
    links = joining(first, second, is_sweet, size)
    estimate = np.full((len(targets), 3), np.nan)
    covariance = np.full((len(targets), 3, 3), np.nan)
    rows_of = {False: is_sweet, True: is_sweet | links}
    pairs_of = {(True,): [np.ones(len(targets), dtype=bool)], (False, True): [sweet, ~sweet]}
    layers = fit_layers(sensor)
    groups = [(rows, rows_of[layer]) for rows, layer in zip(pairs_of[layers], layers, strict=True)]
    used = 0
    slots = np.array([lookup.get(int(t), -1) for t in targets], dtype=np.int64)
    for rows, chosen in groups:
        wanted = rows & (slots >= 0)
        if not wanted.any() or not chosen.any():
            continue
        fit = solve(size, select_rows(measured, chosen), robust)
        origin = np.zeros(int(wanted.sum()), dtype=np.int64)
        estimate[wanted], covariance[wanted] = fit.relative(origin, slots[wanted])
        used = max(used, int(chosen.sum()))
    return estimate, covariance, used
