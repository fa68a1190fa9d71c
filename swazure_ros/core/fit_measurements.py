"""Which measurements a fit takes, both directions of each pair, and outliers to test it with.

A fit takes every visible sweet pair, and the visible decaying pairs that
join two parts of the sweet graph (:func:`joining`, :func:`fit_pairs`);
under a deterministic sensor a pair with a sweet path takes the sweet hops
alone (:func:`fit_layers`). :func:`measurements` measures both directions
of each pair, bias removed; :func:`with_outliers` turns some of them, a
stand-in for a camera's gross errors.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from .arrays import IntArray
from .draws import standard_normals, uniforms
from .measurement_graph import (
    Measurements,
    measured_rows,
)
from .neighbourhood import Neighbourhood
from .sensor import (
    DECAYING,
    SWEET,
    Sensor,
    measured_vectors,
)

Corruption = Callable[[Measurements], Measurements]


def joining(
    first: IntArray, second: IntArray, sweet: NDArray[np.bool_], size: int
) -> NDArray[np.bool_]:
    """Which of the hops first[m] - second[m] (M,) are decaying and join two sweet parts.

    ``sweet`` (M,) marks the sweet hops; the parts are the connected
    components of those over ``size`` FLSs. The one rule of which decaying
    hops a fit takes (docs/core.md, "The least-squares fit").
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    graph = coo_matrix(
        (np.ones(int(sweet.sum())), (first[sweet], second[sweet])), shape=(size, size)
    )
    _, part = connected_components(graph, directed=False)
    return np.asarray(~sweet & (part[first] != part[second]), dtype=np.bool_)


def fit_layers(sensor: Sensor) -> tuple[bool, ...]:
    """The fits a sensor's pairs take, each with or without the joining decaying hops.

    A stochastic sensor: one fit with them, for every pair. A deterministic
    one (its bias unknown and alike on every hop): the sweet hops alone for
    the pairs with a sweet path, then a fit with the joining hops for the rest.
    """
    return (True,) if sensor.noise is not None else (False, True)


def fit_pairs(hood: Neighbourhood, links: bool = True) -> IntArray:
    """Indices into ``hood.pairs`` of the measured pairs a fit uses, ascending.

    Every visible sweet pair; with ``links``, also every visible decaying
    pair that joins two parts of S_vis (:func:`joining`).
    """
    pairs = hood.pairs
    measured = (pairs.range_class == SWEET) | (pairs.range_class == DECAYING)
    index = np.flatnonzero(measured & hood.visible & hood.usable)
    sweet = pairs.range_class[index] == SWEET
    if links:
        first, second = pairs.first[index], pairs.second[index]
        sweet = sweet | joining(first, second, sweet, hood.swarm.size)
    return np.asarray(index[sweet], dtype=np.int64)


def measurements(hood: Neighbourhood, index: IntArray) -> Measurements:
    """Both measurements of each pair of ``hood.pairs`` at ``index`` (P,): (2P,), bias removed."""
    swarm, sensor = hood.swarm, hood.sensor
    low, high = hood.pairs.first[index], hood.pairs.second[index]
    first = np.concatenate([low, high])
    second = np.concatenate([high, low])
    raw = measured_vectors(sensor, swarm.points, swarm.radius, first, second)
    tracking = np.tile(hood.pairs.tracking[index], 2)
    return measured_rows(sensor, swarm.radius, first, second, raw, tracking)


def with_outliers(
    measured: Measurements, fraction: float, angle_deg: float, seed: int = 0
) -> Measurements:
    """``measured`` with a ``fraction`` of its vectors turned by ``angle_deg`` about a random axis.

    A stand-in for a camera's gross errors, such as IPPE's mirrored pose: a
    wrong pose puts the FLS's centre, which lies behind the marker, off to
    one side. Which vectors turn and about which axis (normal to the vector)
    is drawn from ``seed`` and the pair, so a run repeats.
    """
    pick = uniforms(seed, [measured.first, measured.second], 1)[:, 0] < fraction
    vectors = measured.vectors.copy()
    chosen = vectors[pick]
    length = np.linalg.norm(chosen, axis=1, keepdims=True)
    unit = chosen / length
    z = standard_normals(seed + 1, [measured.first[pick], measured.second[pick]], 3)
    axis = np.cross(unit, z)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    turn = np.radians(angle_deg)
    # Rodrigues' rotation of a vector about an axis normal to it.
    vectors[pick] = chosen * np.cos(turn) + np.cross(axis, chosen) * np.sin(turn)
    return replace(measured, vectors=vectors)


def select_rows(measured: Measurements, rows: NDArray[np.bool_]) -> Measurements:
    """The measurements at ``rows``."""
    return Measurements(
        measured.first[rows],
        measured.second[rows],
        measured.vectors[rows],
        measured.covariance[rows],
        measured.information[rows],
    )
