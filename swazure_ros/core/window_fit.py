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
from .fit_measurements import fit_groups, joining, select_rows
from .least_squares import solve
from .measurement_graph import Measurements, measured_rows
from .observe import Observations
from .sensor import BLIND, SWEET, Sensor


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
    """The window of a source and the readings it hears there.

    The window is the source and the FLSs within its radio range (its blind
    and sweet neighbours; spec, section 4); the readings are those of window
    FLSs of other window FLSs, as the ``measurements`` messages bring them.

    Parameters
    ----------
    seen : Observations
        What every FLS's senses give it (:func:`~.observe.observations`).
    ids : (N,) ndarray of int
        The FLS id of each swarm index.
    source : int
        The source's swarm index.

    Returns
    -------
    window : (W,) ndarray of int
        FLS ids, the source first.
    heard : Heard
        The readings between them.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.observe import observations
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> seen = observations(neighbourhood(swarm, sensor))
    >>> window, heard = heard_in_window(seen, np.array([10, 11, 12, 13]), 0)
    >>> window.tolist(), heard.owner.tolist(), heard.other.tolist()
    ([10, 11, 12], [10, 11, 11, 12], [11, 10, 12, 11])
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
        seen.vector_at(rows),
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
    """A source's own fit of some targets from what it hears (docs/core.md, "Own fit").

    The readings are chosen and fitted as :func:`~.pair_fits.fit_pairs_estimates`
    does, over the window's own sweet graph, in (owner, other) order so that a
    node and the engine sum in one order; the source is the origin.

    Parameters
    ----------
    sensor : Sensor
        The swarm's sensor: the readings' covariances, cm^2.
    radius : float, cm
        The FLSs' radius r.
    window : (W,) ndarray of int
        FLS ids, the source first (:func:`heard_in_window`).
    heard : Heard
        The readings between them.
    targets : (K,) ndarray of int
        FLS ids to estimate.
    sweet : (K,) ndarray of bool
        The targets with a sweet path.
    robust : bool, optional
        Whether to reweight and reject outliers (:func:`~.least_squares.solve`).

    Returns
    -------
    estimate : (K, 3) ndarray of float, cm
        Each target from the source; NaN where the window does not join it to
        the source.
    covariance : (K, 3, 3) ndarray of float, cm^2
        Their covariances; NaN likewise.
    used : int
        The readings of the largest fit.

    Raises
    ------
    ValueError
        A reading names an FLS out of the window.

    Examples
    --------
    A source's blind neighbour through their common sweet neighbour, read
    without error:

    >>> import numpy as np
    >>> from swazure_ros.core.sensor import SWEET, Sensor
    >>> readings = Heard(
    ...     np.array([10, 11, 11, 12]), np.array([11, 10, 12, 11]), np.full(4, SWEET, np.int8),
    ...     np.full(4, 6.3), np.array([[2.0, 7, 0], [-2, -7, 0], [2, -7, 0], [-2, 7, 0]]),
    ... )
    >>> window, target, sweet = np.array([10, 11, 12]), np.array([12]), np.array([True])
    >>> exact = Sensor(6.0, 8.0, 8.0, 30.0)
    >>> estimate, _, used = window_fit(exact, 0.5, window, readings, target, sweet)
    >>> estimate.round(9).tolist(), used
    ([[4.0, 0.0, 0.0]], 4)
    """
    slot_of, measured, is_sweet = _window_rows(sensor, radius, window, heard)
    size = len(window)
    links = joining(measured.first, measured.second, is_sweet, size)
    estimate = np.full((len(targets), 3), np.nan)
    covariance = np.full((len(targets), 3, 3), np.nan)
    used = 0
    slots = np.array([slot_of.get(int(t), -1) for t in targets], dtype=np.int64)
    for rows, chosen in fit_groups(sensor, sweet, is_sweet, is_sweet | links):
        wanted = rows & (slots >= 0)
        if not wanted.any() or not chosen.any():
            continue
        fit = solve(size, select_rows(measured, chosen), robust)
        origin = np.zeros(int(wanted.sum()), dtype=np.int64)
        estimate[wanted], covariance[wanted] = fit.relative(origin, slots[wanted])
        used = max(used, int(chosen.sum()))
    return estimate, covariance, used


def _window_rows(
    sensor: Sensor, radius: float, window: IntArray, heard: Heard
) -> tuple[dict[int, int], Measurements, NDArray[np.bool_]]:
    """Each window FLS's place, the readings as measurements in (owner, other) order over
    those places, and which of them are sweet."""
    order = np.lexsort((heard.other, heard.owner))
    slot_of = {int(fls): slot for slot, fls in enumerate(window.tolist())}
    try:
        first = np.array([slot_of[int(f)] for f in heard.owner[order]], dtype=np.int64)
        second = np.array([slot_of[int(f)] for f in heard.other[order]], dtype=np.int64)
    except KeyError as missing:
        raise ValueError(f"a reading names FLS {missing}, which is not in the window") from None
    measured = measured_rows(
        sensor, radius, first, second, heard.vector[order], heard.tracking[order]
    )
    return slot_of, measured, heard.range_class[order] == SWEET
