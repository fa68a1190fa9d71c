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
from .hop_errors import measured_vectors
from .measurement_graph import Measurements, measured_rows
from .neighbourhood import Neighbourhood
from .sensor import DECAYING, SWEET, Sensor

Corruption = Callable[[Measurements], Measurements]


def joining(
    first: IntArray, second: IntArray, sweet: NDArray[np.bool_], size: int
) -> NDArray[np.bool_]:
    """Which hops are decaying and join two parts of the sweet hops' graph.

    The one rule of which decaying hops a fit takes (docs/core.md, "The
    least-squares fit"): a decaying hop within a part adds little to its
    sweet hops and would carry its larger error into the part.

    Parameters
    ----------
    first, second : (M,) ndarray of int
        The hops' ends, FLS indices below ``size``.
    sweet : (M,) ndarray of bool
        The sweet hops; the others are decaying.
    size : int
        N, the FLSs; the parts are the connected components of the sweet
        hops over them.

    Returns
    -------
    (M,) ndarray of bool
        The decaying hops whose ends lie in two parts.

    Examples
    --------
    >>> import numpy as np
    >>> sweet = np.array([True, True, False, False])  # 0-1-2 one part, 3 alone
    >>> joining(np.array([0, 1, 0, 2]), np.array([1, 2, 2, 3]), sweet, 4).tolist()
    [False, False, False, True]
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

    A stochastic sensor: one fit with them, for every pair (its bias is
    removed and its scatter known, so every joining hop only adds). A
    deterministic one (its bias unknown and alike on every hop): the sweet
    hops alone for the pairs with a sweet path, then a fit with the joining
    hops for the rest.

    Parameters
    ----------
    sensor : Sensor
        The swarm's sensor.

    Returns
    -------
    tuple of bool
        Per fit, whether it takes the joining decaying hops.

    Examples
    --------
    >>> from swazure_ros.core.sensor import Sensor
    >>> fit_layers(Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755)))
    (False, True)
    """
    return (True,) if sensor.noise is not None else (False, True)


def fit_groups(
    sensor: Sensor,
    sweet: NDArray[np.bool_],
    sweet_rows: NDArray[np.bool_],
    linked_rows: NDArray[np.bool_],
) -> list[tuple[NDArray[np.bool_], NDArray[np.bool_]]]:
    """Each fit that a sensor's pairs take (:func:`fit_layers`): its pairs and its rows.

    Parameters
    ----------
    sensor : Sensor
        The swarm's sensor.
    sweet : (M,) ndarray of bool
        The pairs to estimate that have a sweet path.
    sweet_rows, linked_rows : (R,) ndarray of bool
        The measurements a fit of the sweet hops alone takes, and one with the
        joining decaying hops too.

    Returns
    -------
    list of tuple of two ndarray of bool
        Per fit, the pairs (M,) it estimates and the rows (R,) it takes.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> sweet, rows = np.array([True, False]), np.array([True, False, True])
    >>> for pairs, taken in fit_groups(sensor, sweet, rows, np.ones(3, dtype=bool)):
    ...     print(pairs.tolist(), taken.tolist())
    [True, False] [True, False, True]
    [False, True] [True, True, True]
    """
    rows_of = {False: sweet_rows, True: linked_rows}
    pairs_of = {(True,): [np.ones(len(sweet), dtype=bool)], (False, True): [sweet, ~sweet]}
    layers = fit_layers(sensor)
    return [(pairs, rows_of[layer]) for pairs, layer in zip(pairs_of[layers], layers, strict=True)]


def fit_pairs(hood: Neighbourhood, links: bool = True) -> IntArray:
    """The measured pairs a fit uses: the sweet pairs in sight, and decaying ones that join parts.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood; the pairs its paths may not use
        (:func:`~.neighbourhood.without`) are left out.
    links : bool, optional
        Whether to add the decaying pairs in sight that join two parts of S_vis
        (:func:`joining`).

    Returns
    -------
    (P,) ndarray of int
        Indices into ``hood.pairs``, ascending.

    Examples
    --------
    A-B and B-C are sweet; the fourth FLS, D, is joined to them by decaying pairs:

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> [(int(hood.pairs.first[i]), int(hood.pairs.second[i])) for i in fit_pairs(hood)]
    [(0, 1), (0, 3), (1, 2), (1, 3), (2, 3)]
    >>> fit_pairs(hood, links=False).tolist() == [0, 3]
    True
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
    """Both measurements of each of some pairs, as a fit takes them: bias removed, covariances.

    Parameters
    ----------
    hood : Neighbourhood
        The swarm's neighbourhood.
    index : (P,) ndarray of int
        Indices into ``hood.pairs`` (:func:`fit_pairs`).

    Returns
    -------
    Measurements
        2P rows: each pair from its first FLS, then each from its second;
        vectors, cm, their covariances, cm^2, and information, cm^-2.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.geometry import make_swarm
    >>> from swazure_ros.core.neighbourhood import neighbourhood
    >>> from swazure_ros.core.sensor import Sensor
    >>> sensor = Sensor(6.0, 8.0, 8.0, 30.0, (0.00180987, -0.02756392, 0.11561755))
    >>> swarm = make_swarm(np.array([[0.0, 0, 0], [2, 7, 0], [4, 0, 0], [2, -10, 0]]), radius=0.5)
    >>> hood = neighbourhood(swarm, sensor)
    >>> measured = measurements(hood, fit_pairs(hood, links=False))
    >>> measured.first.tolist(), measured.second.tolist()
    ([0, 1, 1, 2], [1, 2, 0, 1])
    >>> measured.vectors.shape, measured.covariance.shape
    ((4, 3), (4, 3, 3))
    """
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
    """Measurements with a share of their vectors turned by an angle about a random axis.

    A stand-in for a camera's gross errors, such as IPPE's mirrored pose: a
    wrong pose puts the FLS's centre, which lies behind the marker, off to
    one side. Which vectors turn and about which axis (normal to the vector)
    is drawn from ``seed`` and the pair, so a run repeats.

    Parameters
    ----------
    measured : Measurements
        M measurements.
    fraction : float
        The share of them to turn, 0 to 1 (each turns with this chance).
    angle_deg : float, degrees
        How far each turns.
    seed : int, optional
        The draws' seed.

    Returns
    -------
    Measurements
        ``measured`` with the turned vectors; covariances unchanged.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> eye = np.broadcast_to(np.eye(3), (2, 3, 3))
    >>> vectors = np.array([[7.0, 0, 0], [-7.0, 0, 0]])
    >>> measured = Measurements(np.array([0, 1]), np.array([1, 0]), vectors, eye, eye)
    >>> turned = with_outliers(measured, 1.0, 90.0)
    >>> bool(np.allclose(turned.vectors @ [1.0, 0, 0], 0.0))  # at right angles to before
    True
    >>> np.linalg.norm(turned.vectors, axis=1).round(9).tolist()  # as long as before
    [7.0, 7.0]
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
    """The measurements at some rows.

    Parameters
    ----------
    measured : Measurements
        M measurements.
    rows : (M,) ndarray of bool
        The rows to keep.

    Returns
    -------
    Measurements
        The kept rows, in order.

    Examples
    --------

    >>> import numpy as np
    >>> from swazure_ros.core.measurement_graph import Measurements
    >>> eye = np.broadcast_to(np.eye(3), (2, 3, 3))
    >>> vectors = np.array([[7.0, 0, 0], [-7.0, 0, 0]])
    >>> measured = Measurements(np.array([0, 1]), np.array([1, 0]), vectors, eye, eye)
    >>> select_rows(measured, np.array([False, True])).vectors.tolist()
    [[-7.0, 0.0, 0.0]]
    """
    return Measurements(
        measured.first[rows],
        measured.second[rows],
        measured.vectors[rows],
        measured.covariance[rows],
        measured.information[rows],
    )
