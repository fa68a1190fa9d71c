"""Circles in space: the free point of a circle among blocking spheres, where it meets a sphere.

Move Obstructing (:mod:`.heuristics.obstructing`) moves an FLS along a
circle around the segment it obstructs; these find the circle's point nearest
its ideal move that no other FLS's sphere covers, exactly, and where the
circle crosses a sphere's surface.
"""

from __future__ import annotations

import numpy as np

from . import jit
from .arrays import FloatArray


def free_circle_point(
    centre: FloatArray,
    normal: FloatArray,
    toward: FloatArray,
    radius: float,
    blockers: FloatArray,
    block_radius: float,
) -> FloatArray | None:
    """The point of a circle nearest ``toward`` that is not strictly inside any blocking sphere.

    The circle has centre ``centre``, radius ``radius`` and lies in the plane
    through ``centre`` perpendicular to ``normal``; each row of ``blockers``
    (B, 3) is the centre of a sphere of radius ``block_radius`` whose interior
    is removed. Exact: each sphere removes one open arc, computed in closed
    form. Move Obstructing's obstruction-free circle (spec, section 7).

    Parameters
    ----------
    centre : (3,) array of float, cm
        The circle's centre.
    normal : (3,) array of float
        The normal of the circle's plane; any non-zero length.
    toward : (3,) array of float, cm
        The point to be nearest to (the obstructing FLS's centre).
    radius : float, cm
        The circle's radius.
    blockers : (B, 3) array of float, cm
        Centres of the blocking spheres; B may be 0.
    block_radius : float, cm
        Their radius.

    Returns
    -------
    (3,) array of float, cm, or None
        The free point nearest ``toward`` (ties: the positive angle), or None
        when nothing of the circle remains free.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.circles import free_circle_point
    >>> free_circle_point(np.zeros(3), np.array([0.0, 0, 1]), np.array([5.0, 0, 0]), 1.0,
    ...                   np.empty((0, 3)), 1.0)
    array([1., 0., 0.])
    """
    point: FloatArray = free_circle_kernel(
        np.asarray(centre, dtype=np.float64),
        np.asarray(normal, dtype=np.float64),
        np.asarray(toward, dtype=np.float64),
        float(radius),
        np.ascontiguousarray(blockers, dtype=np.float64).reshape(-1, 3),
        float(block_radius),
    )
    return None if np.isnan(point[0]) else point


@jit.kernel(cache=True)
def _wrap(angle: float) -> float:
    return (angle + np.pi) % (2 * np.pi) - np.pi


@jit.kernel(cache=True)
def free_circle_kernel(
    centre: FloatArray,
    normal: FloatArray,
    toward: FloatArray,
    radius: float,
    blockers: FloatArray,
    block_radius: float,
) -> FloatArray:
    """:func:`free_circle_point` compiled, for kernels: a NaN point where nothing is free.

    Parameters
    ----------
    centre, normal, toward : (3,) array of float
        As :func:`free_circle_point`'s, float64.
    radius : float, cm
    blockers : (B, 3) array of float, cm
        Contiguous, float64; B may be 0.
    block_radius : float, cm

    Returns
    -------
    (3,) array of float, cm
        The free point nearest ``toward``; NaN where nothing of the circle is free.
    """
    normal = normal / np.sqrt(normal @ normal)
    offset = toward - centre
    offset = offset - (offset @ normal) * normal
    if np.sqrt(offset @ offset) < 1e-12 * max(radius, 1.0):
        # Exactly on the line: any direction is nearest; take a fixed one.
        axis = np.zeros(3)
        axis[np.argmin(np.abs(normal))] = 1.0
        offset = np.cross(normal, axis)
    first = offset / np.sqrt(offset @ offset)
    second = np.cross(normal, first)
    # |q(θ) - s|² < R²  <=>  A cos θ + B sin θ < m, with q(θ) = c + r (cos θ e1 + sin θ e2).
    phases = np.empty(len(blockers))
    halves = np.empty(len(blockers))
    arcs = 0
    for k in range(len(blockers)):
        relative = centre - blockers[k]
        a, b = relative @ first, relative @ second
        m = -(relative @ relative + radius**2 - block_radius**2) / (2 * radius)
        rho = np.hypot(a, b)
        if (rho == 0 and m > 0) or (rho > 0 and m > rho):
            return np.full(3, np.nan)  # this sphere covers the whole circle
        if rho > 0 and m > -rho:
            phases[arcs] = np.arctan2(b, a) + np.pi  # centre of the removed arc
            halves[arcs] = np.pi - np.arccos(min(max(m / rho, -1.0), 1.0))
            arcs += 1
    # Candidates: θ = 0 (the ideal move) and every arc end; nearest = smallest |θ|, then +θ.
    best = np.nan
    for candidate in range(2 * arcs + 1):
        if candidate == 0:
            theta = 0.0
        elif candidate <= arcs:
            theta = _wrap(phases[candidate - 1] - halves[candidate - 1])
        else:
            theta = _wrap(phases[candidate - 1 - arcs] + halves[candidate - 1 - arcs])
        free = True
        for k in range(arcs):
            if abs(_wrap(theta - phases[k])) < halves[k] - 1e-12:
                free = False
                break
        if free and (
            np.isnan(best) or abs(theta) < abs(best) or (abs(theta) == abs(best) and theta > best)
        ):
            best = theta
    if np.isnan(best):
        return np.full(3, np.nan)
    point: FloatArray = centre + radius * (np.cos(best) * first + np.sin(best) * second)
    return point


def circle_sphere_crossings(
    centre: FloatArray,
    normal: FloatArray,
    radius: float,
    sphere: FloatArray,
    sphere_radius: float,
) -> FloatArray:
    """Points (0 to 2, 3) where a circle meets a sphere's surface, cm.

    A tangent circle gives its one point twice.

    Parameters
    ----------
    centre : (3,) array of float, cm
        The circle's centre.
    normal : (3,) array of float
        The normal of the circle's plane; any non-zero length.
    radius : float, cm
        The circle's radius, > 0.
    sphere : (3,) array of float, cm
        The sphere's centre.
    sphere_radius : float, cm
        The sphere's radius.

    Returns
    -------
    (K, 3) array of float, cm
        K = 2 crossings (equal when tangent), or K = 0 when the circle does not
        meet the surface or the sphere's centre lies on the circle's axis.
    """
    normal = normal / np.linalg.norm(normal)
    first = fixed_axis(normal)
    second = np.cross(normal, first)
    # |c + r (cos θ e1 + sin θ e2) - s|² = R²  <=>  a cos θ + b sin θ = m.
    relative = centre - sphere
    a, b = float(relative @ first), float(relative @ second)
    m = (sphere_radius**2 - relative @ relative - radius**2) / (2.0 * radius)
    rho = float(np.hypot(a, b))
    if rho == 0.0 or abs(m) > rho:
        return np.zeros((0, 3))
    phase, half = np.arctan2(b, a), np.arccos(m / rho)
    theta = np.array([phase - half, phase + half])
    return np.asarray(
        centre + radius * (np.cos(theta)[:, None] * first + np.sin(theta)[:, None] * second)
    )


def fixed_axis(normal: FloatArray) -> FloatArray:
    """A fixed unit vector in the plane perpendicular to ``normal``: ``normal`` crossed with
    the coordinate axis least along it. Where a circle's points are all as near (a point on
    its axis), the one this direction reaches is taken.

    Parameters
    ----------
    normal : (3,) array of float
        The normal of the plane, unit length.

    Returns
    -------
    (3,) array of float
        Unit length, perpendicular to ``normal``.

    Examples
    --------
    >>> import numpy as np
    >>> from swazure_ros.core.circles import fixed_axis
    >>> fixed_axis(np.array([1.0, 0.0, 0.0]))
    array([0., 0., 1.])
    """
    axis = np.zeros(3)
    axis[np.argmin(np.abs(normal))] = 1.0
    first = np.cross(normal, axis)
    first /= np.linalg.norm(first)
    return np.asarray(first)
