"""Measurements, sensors and swarms that the fit's tests share."""

import numpy as np

from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.measurement_graph import Measurements
from swazure_ros.core.sensor import Sensor, SensorNoise
from swazure_ros.files.cloud_files import load_cloud


def stochastic_sensor(mean_error=0.0, sd=0.01, direction_deg=0.2):
    """The published ranges with a seeded scatter and a known bias."""
    noise = SensorNoise(
        tracking_cm=(0.0, 30.0),
        mean_error=(mean_error, mean_error),
        detection=(1.0, 1.0),
        distance_sd=(sd, sd),
        direction_sd_deg=(direction_deg, direction_deg),
        seed=3,
    )
    return Sensor(6.0, 8.0, 8.0, 30.0, name="scatter", noise=noise)


def exact(first, second, vectors, variance=1.0):
    """Measurements (M,) of the vectors (M, 3) with an isotropic variance, cm^2."""
    count = len(first)
    eye = np.broadcast_to(np.eye(3), (count, 3, 3))
    return Measurements(
        np.asarray(first),
        np.asarray(second),
        np.asarray(vectors, dtype=float),
        eye * variance,
        eye / variance,
    )


def torus_swarm(beta=0.3, shape="torus:120"):
    """At beta 0.3: torus:120's blind pairs have a sweet path or none, a helix's a decaying one."""
    return make_swarm(load_cloud(shape).points * 1.6, beta=beta)
