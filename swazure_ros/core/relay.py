"""Relay choice for tracking a neighbour out of sight (spec, section 9).

A source FLS that cannot see its target receives the target's relative
position from a relay: an FLS in the source's sweet range that sees the
target (:func:`choose_relay`, :func:`next_relay` when one loses it). The
relay measures both hops with its own camera at one instant and sends their
sum (:func:`relay_sample`); :class:`RelaySenses` does both by FLS id with
every FLS where it is at a given time. Units: s, cm.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arrays import FloatArray
from .errors import UnknownFlsError
from .geometry import tracking_distance
from .hop_errors import measured_vectors
from .motion import Motion
from .sensor import DECAYING, SWEET, Sensor
from .sight import obstructed

# What a relay reports with each sample.
RELAY_OK = 0
RELAY_TARGET_LOST = 1  # the relay's camera no longer sees the target
RELAY_SOURCE_LOST = 2  # the source left the relay's sweet range or view

RELAY_MESSAGES = {
    RELAY_TARGET_LOST: "the relay lost sight of the target",
    RELAY_SOURCE_LOST: "the source left the relay's sweet range or view",
}


def _seen(
    sensor: Sensor, points: FloatArray, radius: float, first: ArrayLike, second: ArrayLike
) -> NDArray[np.int8]:
    """(M,) range class of each second[m] as first[m]'s camera sees it now, or -1 if it cannot."""
    first = np.atleast_1d(np.asarray(first, dtype=np.int64))
    second = np.atleast_1d(np.asarray(second, dtype=np.int64))
    classes = sensor.classify(tracking_distance(points, radius, first, second))
    measurable = (classes == SWEET) | (classes == DECAYING)
    # One line-of-sight query (one grid) for every segment in range.
    blocked = obstructed(points, radius, first[measurable], second[measurable])
    measurable[np.flatnonzero(measurable)[blocked]] = False
    return np.where(measurable, classes, -1).astype(np.int8)


def choose_relay(
    sensor: Sensor, points: FloatArray, radius: float, source: int, target: int
) -> int | None:
    """Index of the relay for source -> target, or None: a sweet neighbour that sees the target.

    Both hops need line of sight. Preferred: a target in the relay's sweet
    range over its decaying range, then the shortest two-hop tracking length
    (to 1e-7 cm, so that symmetric swarms tie whatever the rounding), then
    the lowest index.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, target : int
        Indices into ``points``.

    Returns
    -------
    int or None
        The relay's index; None when no sweet neighbour of the source sees
        the target.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [3, 0, 0], [0, 8, 0], [3, 8.2, 0]])  # cm, r = 0.5
    >>> from swazure_ros.core.relay import choose_relay
    >>> choose_relay(published, points, 0.5, 0, 1)  # FLS 2: 7 cm from 0, 7.54 cm from 1
    2
    """
    everyone = np.arange(len(points))
    tracking = tracking_distance(points, radius, np.full(len(points), source), everyone)
    candidates = np.flatnonzero(sensor.classify(tracking) == SWEET)
    candidates = candidates[(candidates != source) & (candidates != target)]
    count = len(candidates)
    seen = _seen(
        sensor,
        points,
        radius,
        np.concatenate([np.full(count, source), candidates]),
        np.concatenate([candidates, np.full(count, target)]),
    )
    from_source, to_target = seen[:count], seen[count:]
    usable = (from_source == SWEET) & (to_target >= 0)
    if not usable.any():
        return None
    relays = candidates[usable]
    length = tracking[relays] + tracking_distance(
        points, radius, relays, np.full(len(relays), target)
    )
    # Lengths equal to a nanometre tie, so that symmetric swarms go to the lowest
    # index whatever rounding the distances took. lexsort: last key sorts first.
    order = np.lexsort((relays, np.round(length, 7), to_target[usable] != SWEET))
    return int(relays[order[0]])


def next_relay(
    sensor: Sensor, points: FloatArray, radius: float, source: int, target: int, relay: int
) -> int | None:
    """Index of the relay to hand a stream over to when ``relay`` lost it, or None.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, target, relay : int
        Indices into ``points``.

    Returns
    -------
    int or None
        :func:`choose_relay`'s choice, or None when it is ``relay`` again or
        there is none.
    """
    successor = choose_relay(sensor, points, radius, source, target)
    return None if successor is None or successor == relay else successor


def relay_sample(
    sensor: Sensor, points: FloatArray, radius: float, source: int, relay: int, target: int
) -> tuple[int, FloatArray]:
    """One relayed sample: the hop source -> relay plus relay -> target, cm.

    The relay measures both with its own camera at one instant: the hop is
    minus its measurement of the source, as Swazure sums measured hop vectors.

    Parameters
    ----------
    sensor : Sensor
    points : (N, 3) array of float, cm
        Where every FLS is now.
    radius : float, cm
        The FLS radius r.
    source, relay, target : int
        Indices into ``points``.

    Returns
    -------
    status : int
        RELAY_OK; RELAY_SOURCE_LOST when the source is no longer a sweet
        neighbour in the relay's sight; RELAY_TARGET_LOST when the relay no
        longer sees the target in its sweet or decaying range.
    sample : (3,) array of float, cm
        The target relative to the source; NaN unless RELAY_OK.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import Sensor
    >>> published = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> points = np.array([[0.0, 0, 0], [3, 0, 0], [0, 8, 0], [3, 8.2, 0]])  # cm, r = 0.5
    >>> from swazure_ros.core.relay import relay_sample
    >>> status, sample = relay_sample(published, points, 0.5, 0, 2, 1)
    >>> status, sample.round(2)  # the truth is (3, 0, 0); each hop errs by about 1 %
    (0, array([3.03, 0.  , 0.  ]))
    """
    to_source, to_target = _seen(sensor, points, radius, [relay, relay], [source, target])
    if to_source != SWEET:
        return RELAY_SOURCE_LOST, np.full(3, np.nan)
    if to_target < 0:
        return RELAY_TARGET_LOST, np.full(3, np.nan)
    measured = measured_vectors(sensor, points, radius, [relay, relay], [source, target])
    return RELAY_OK, measured[1] - measured[0]


class RelaySenses:
    """Relay choice and relayed samples by FLS id, with every FLS where it is at a given time.

    ``ids`` (N,) are the FLS ids of the rows of ``positions(seconds)``, which
    gives (N, 3) positions, cm; ``radius`` in cm.
    """

    def __init__(
        self,
        sensor: Sensor,
        radius: float,
        ids: NDArray[np.int64],
        positions: Callable[[float], FloatArray],
    ) -> None:
        self.sensor = sensor
        self.radius = radius
        self.ids = ids
        self.positions = positions

    def row(self, fls_id: int) -> int:
        """Row of FLS ``fls_id``; UnknownFlsError when the swarm has none."""
        row = int(np.searchsorted(self.ids, fls_id))
        if row >= len(self.ids) or self.ids[row] != fls_id:
            raise UnknownFlsError(f"no FLS {fls_id} in this swarm of {len(self.ids)} FLSs")
        return row

    def _fls_id(self, row: int | None) -> int | None:
        return None if row is None else int(self.ids[row])

    def choose_relay(self, source: int, target: int, seconds: float) -> int | None:
        """The relay for ``source`` to track ``target`` at ``seconds`` (:func:`choose_relay`)."""
        points = self.positions(seconds)
        relay = choose_relay(self.sensor, points, self.radius, self.row(source), self.row(target))
        return self._fls_id(relay)

    def next_relay(self, source: int, target: int, relay: int, seconds: float) -> int | None:
        """The relay to hand ``relay``'s stream over to at ``seconds`` (:func:`next_relay`)."""
        points = self.positions(seconds)
        rows = (self.row(source), self.row(target), self.row(relay))
        return self._fls_id(next_relay(self.sensor, points, self.radius, *rows))

    def track_sample(
        self, source: int, relay: int, target: int, seconds: float
    ) -> tuple[int, FloatArray]:
        """(status, (3,) cm) ``relay`` senses for ``source`` at ``seconds``: relay_sample."""
        points = self.positions(seconds)
        rows = (self.row(source), self.row(relay), self.row(target))
        return relay_sample(self.sensor, points, self.radius, *rows)


def moving_senses(
    sensor: Sensor, radius: float, ids: NDArray[np.int64], home: FloatArray, motion: Motion
) -> RelaySenses:
    """Relay senses of FLSs that start at ``home`` and move by ``motion``.

    Parameters
    ----------
    sensor : Sensor
    radius : float, cm
        The FLS radius r.
    ids : (N,) array of int
        The FLS ids of the rows of ``home``, sorted.
    home : (N, 3) array of float, cm
        Where each FLS is at t = 0.
    motion : Motion
        Which FLSs move and how; the others stay home.

    Returns
    -------
    RelaySenses
        Relay choice and relayed samples by FLS id, at any time in s.
    """
    return RelaySenses(sensor, radius, ids, lambda seconds: motion.points(home, ids, seconds))
