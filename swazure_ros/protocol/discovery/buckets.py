"""A phase's buckets: what one round of a path search costs, and how far a pass reaches.

A round relaxes the labels of one bucket (:mod:`.search`): the bucket's width is
the smallest cost a hop can add under the policy, so that a label sent in a round
is final. A pass relays labels only up to its reach, in rounds; a source cut short
searches again in the next pass, twice as far (docs/protocol.md).
"""

from __future__ import annotations

import math

import numpy as np

from ...core.hop_errors import hop_error, smallest_hop_error
from ...core.paths import FEWEST_HOPS, LEAST_ERROR, check_policy
from ...core.sensor import Sensor

#: Rounds that one sweet hop may cost in a least-error run, at most: the calibrated
#: sensors' cost 24 and 88; a sensor whose error crosses zero in its range, tens of thousands.
MAX_ROUNDS_PER_HOP = 1000


#: Bucket widths sit this fraction below the shortest hop, so that rounding in
#: a sum of lengths never puts a label in the bucket of the label it extends.
_BUCKET_MARGIN = 1e-9


#: A phase's first reach: the rounds that this many of the costliest sweet hops take.
#: A source's targets are its blind neighbours, a few sweet hops away: most searches end
#: within it, and the few cut short search again twice as far (docs/protocol.md).
REACH_HOPS = 8


def refusal(sensor: Sensor, radius: float, policy: str) -> str | None:
    """Why FLSs with ``sensor`` and ``radius`` (cm) cannot search by ``policy``; or None."""
    try:
        bucket_width(sensor, radius, policy)
    except ValueError as err:
        return str(err)
    return None


def bucket_width(sensor: Sensor, radius: float, policy: str) -> float:
    """Cost per round: the smallest cost a hop can add under ``policy``, a little lowered.

    One hop for fewest-hops; just under ``sweet_min`` cm for shortest-length;
    :func:`~..core.hop_errors.smallest_hop_error` for least-error.
    """
    if check_policy(policy) == FEWEST_HOPS:
        return 1.0
    if policy == LEAST_ERROR:
        smallest = smallest_hop_error(sensor, radius)
        if not smallest > 0:
            raise ValueError(
                f"least-error needs a sensor whose every hop errs; {sensor.name} has hops "
                "without error (an accurate sensor has no least-error path)"
            )
        # A sweet hop's cost in buckets is what one hop costs in rounds: where the
        # error nearly vanishes inside the range, a run would take rounds without end.
        sweet = np.linspace(sensor.sweet_min, sensor.sweet_max, 1001)
        rounds = float(hop_error(sensor, sweet, radius).max() / smallest)
        if rounds > MAX_ROUNDS_PER_HOP:
            raise ValueError(
                f"least-error over {sensor.name or 'this sensor'} would take about "
                f"{rounds:,.0f} rounds a hop (its hop error falls to {smallest:.3g} inside the "
                f"camera's range; at most {MAX_ROUNDS_PER_HOP:,} are allowed): use "
                "shortest-length or fewest-hops"
            )
        return smallest
    # A Sensor's sweet_min is above 0 (core.sensor.Sensor refuses any other).
    return sensor.sweet_min * (1.0 - _BUCKET_MARGIN)


def reach_rounds(sensor: Sensor, radius: float, policy: str, reach_pass: int) -> float:
    """The rounds of a phase in which its pass ``reach_pass`` relays labels: its reach.

    Pass 0 reaches as far as :data:`REACH_HOPS` of the costliest sweet hops,
    in every phase (an SD_vis path too is mostly sweet hops); each later pass
    twice as far as the one before. A label of a later bucket is kept but
    not sent, and its source counted as cut short: its search may go on in
    the next pass. Infinite (no bound) where a hop's cost has none.
    """
    width = bucket_width(sensor, radius, policy)
    longest = sensor.sweet_max
    if policy == FEWEST_HOPS:
        costliest = 1.0
    elif policy == LEAST_ERROR:
        shortest = sensor.sweet_min
        costliest = float(hop_error(sensor, np.linspace(shortest, longest, 1001), radius).max())
    else:
        costliest = longest
    if not np.isfinite(costliest):
        return math.inf
    return float(math.ceil(REACH_HOPS * costliest / width) * 2**reach_pass)
