"""Whether a swarm's spacing fits its sensor, and the ``--scale`` that would (docs/core.md).

A cloud written in metres where centimetres are expected is 100 times too
small: every pair of FLSs is then closer than the sweet range, no pair is a
hop the sensor measures, and every blind pair has no path. A run like that
completes, and its summary would be all "no path". :func:`run_advice` says
why a run's every blind pair has no path (or why it has none), and
:func:`fitting_scale` the factor to multiply the cloud by so that its
spacing fits the sensor; :func:`spacing_advice` says the same before a run,
from the geometry alone. The command line prints them (cli/summary.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .clouds import PUBLISHED_DENSITY, mean_spacing
from .geometry import Swarm
from .sensor import Sensor
from .summary import Summary

#: Centre of the published sensor's sweet range (6 to 8 cm), cm: the published shapes are
#: scaled to PUBLISHED_DENSITY against it, the sweet range about 11 spacings across.
PUBLISHED_SWEET_CENTRE = 7.0
#: Points whose pairwise distances give a cloud's median pair distance, at most (seeded).
_EXTENT_SAMPLE = 1000
#: A factor this close to 1 (within it, or its inverse) is no reason to rescale.
_FITS = 2.0


@dataclass(frozen=True)
class Advice:
    """Why a run's blind pairs have no path, in one line, and the ``--scale`` factor
    that would fit the sensor (None when the spacing is not the cause)."""

    reason: str
    factor: float | None


def fitting_scale(swarm: Swarm, sensor: Sensor) -> float:
    """The factor to multiply ``swarm``'s cloud by so that its spacing fits ``sensor``.

    The larger of two factors, rounded to two significant digits:

    - density: the published shapes have a mean nearest-neighbour spacing of
      ``PUBLISHED_DENSITY`` (0.65 cm) against a sweet range centred at 7 cm;
      the factor that gives this swarm the same spacing relative to the
      centre of its sensor's sweet range;
    - extent: the factor that puts the median distance between two FLSs
      (over at most 1,000 seeded points) at a tracking distance of
      ``sweet_max``, so that a small shape reaches past its blind range.

    With ``r = beta * dmin`` the radius scales with the cloud; an explicit
    radius does not.

    Parameters
    ----------
    swarm : Swarm
        At least two FLSs, cm.
    sensor : Sensor
        Its ranges, cm.

    Returns
    -------
    float
        The factor, > 0: 100 for a published shape written in metres, 1 for
        one that fits.

    Raises
    ------
    ValueError
        The swarm has fewer than two FLSs.

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> from swazure_ros.core.spacing import fitting_scale
    >>> in_metres = make_swarm(builtin_points("torus:120") / 100, beta=0.5)
    >>> fitting_scale(in_metres, Sensor(6.0, 8.0, 8.0, 30.0))
    340.0
    """
    points = np.asarray(swarm.points, dtype=np.float64)
    if len(points) < 2:
        raise ValueError(f"Expected a swarm of at least 2 FLSs, got {len(points)}")
    centre = (sensor.sweet_min + sensor.sweet_max) / 2.0
    density = centre / PUBLISHED_SWEET_CENTRE * PUBLISHED_DENSITY / mean_spacing(points)
    if len(points) > _EXTENT_SAMPLE:
        chosen = np.random.default_rng(0).choice(len(points), _EXTENT_SAMPLE, replace=False)
        points = points[np.sort(chosen)]
    first, second = np.triu_indices(len(points), k=1)
    median = float(np.median(np.linalg.norm(points[first] - points[second], axis=1)))
    if swarm.beta is not None:
        # t = s (d - 2 beta dmin): the tracking distance scales with the cloud.
        reach = median - 2.0 * swarm.beta * swarm.dmin
        extent = sensor.sweet_max / reach if reach > 0 else 0.0
    else:
        extent = (sensor.sweet_max + 2.0 * swarm.radius) / median
    return float(f"{max(density, extent):.2g}")


def _scale_if_off(swarm: Swarm, sensor: Sensor) -> float | None:
    factor = fitting_scale(swarm, sensor)
    return factor if not 1.0 / _FITS <= factor <= _FITS else None


def _no_hop_reason(blind: int, sensor: Sensor) -> str:
    """Why no pair of FLSs is a hop the sensor measures."""
    if blind:
        return (
            f"no pair of FLSs is a hop the sensor measures: every pair is closer than its "
            f"sweet range ({sensor.sweet_min:g} cm) or beyond its reach "
            f"({sensor.decaying_max:g} cm), so no blind pair has a path"
        )
    return (
        f"no pair of FLSs is within the sensor's reach ({sensor.decaying_max:g} cm) and none "
        "is blind: every pair is unreachable, nothing to compute"
    )


#: Units a cloud may have been written in where cm are expected, by the factor to cm.
_UNITS = {"metres": 100.0, "millimetres": 0.1}


def likely_unit(factor: float) -> str | None:
    """The unit a cloud that needs ``factor`` was likely written in, or None.

    Parameters
    ----------
    factor : float
        A :func:`fitting_scale`.

    Returns
    -------
    str or None
        ``"metres"`` for a factor within 3 times of 100, ``"millimetres"``
        within 3 times of 0.1, else None.

    Examples
    --------
    >>> from swazure_ros.core.spacing import likely_unit
    >>> likely_unit(110), likely_unit(0.1), likely_unit(3.4)
    ('metres', 'millimetres', None)
    """
    for unit, to_cm in _UNITS.items():
        if to_cm / 3.0 <= factor <= to_cm * 3.0:
            return unit
    return None


def spacing_advice(swarm: Swarm, sensor: Sensor) -> Advice | None:
    """Before a run: an :class:`Advice` when no pair is a hop the sensor measures, else None.

    Every blind pair would then have no path.

    Counts the pairs whose tracking distance is sweet or decaying with a
    k-d tree (time grows with the pairs within the sensor's reach).

    Parameters
    ----------
    swarm : Swarm
    sensor : Sensor

    Returns
    -------
    Advice or None
        The reason in one line and :func:`fitting_scale`; None when some pair
        is a sweet or decaying hop.

    Examples
    --------
    >>> from swazure_ros.core.clouds import builtin_points
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.sensor import Sensor
    >>> from swazure_ros.core.spacing import spacing_advice
    >>> in_metres = make_swarm(builtin_points("torus:120") / 100, beta=0.5)
    >>> advice = spacing_advice(in_metres, Sensor(6.0, 8.0, 8.0, 30.0))
    >>> advice.reason[:50], advice.factor
    ('no pair of FLSs is a hop the sensor measures: ever', 340.0)
    """
    from scipy.spatial import cKDTree  # here, not at import: an FLS alone never calls it

    twice = 2.0 * swarm.radius
    edges = [
        sensor.sweet_min + twice,
        sensor.sweet_max + twice,
        sensor.decaying_min + twice,
        sensor.decaying_max + twice,
    ]
    tree = cKDTree(swarm.points)
    # Ordered pairs (and each FLS with itself) within each radius, cumulative.
    within = tree.count_neighbors(tree, np.nextafter(np.asarray(edges), 0.0))
    hops = (within[1] - within[0]) + (within[3] - within[2])
    if hops:
        return None
    blind = int(within[0]) - swarm.size
    return Advice(_no_hop_reason(blind, sensor), fitting_scale(swarm, sensor))


def run_advice(summary: Summary, swarm: Swarm, sensor: Sensor) -> Advice | None:
    """After a run: an :class:`Advice` when no blind pair has a path, or there is none.

    None for a run that found paths.

    The reason is the first that holds: no pair is a hop the sensor measures
    (the spacing: the advice names the fitting scale); every blind pair is
    blocked (FLSs in the line of sight); no path of hops joins a blind pair.
    The last two name a scale only when :func:`fitting_scale` is below 1/2
    or above 2.

    Parameters
    ----------
    summary : Summary
        The run's summary: its pair counts and neighbour pair counts.
    swarm : Swarm
        The swarm it ran on.
    sensor : Sensor
        The sensor it ran with.

    Returns
    -------
    Advice or None
    """
    pairs = summary.pairs
    if pairs.blind_pairs and pairs.no_path_pairs < pairs.blind_pairs:
        return None
    hops = summary.sweet_neighbour_pairs + summary.decaying_neighbour_pairs
    if not hops:
        return Advice(_no_hop_reason(pairs.blind_pairs, sensor), fitting_scale(swarm, sensor))
    if not pairs.blind_pairs:
        reason = (
            f"no pair of FLSs is blind (tracking distance below {sensor.sweet_min:g} cm): "
            "every pair is measured directly, nothing is left to compute"
        )
    elif pairs.blocked_pairs == pairs.blind_pairs:
        reason = (
            "every blind pair is blocked: FLSs in the line of sight obstruct the hops that "
            f"would join it ({summary.kissing_pairs} kissing pairs; a smaller beta or "
            "radius clears the view)"
        )
    else:
        reason = (
            f"no path of sweet or decaying hops joins a blind pair ({pairs.blocked_pairs} "
            f"blocked, {pairs.no_sweet_path_pairs} with no sweet path in sight)"
        )
    return Advice(reason, _scale_if_off(swarm, sensor))
