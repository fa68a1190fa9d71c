"""Sensors that the sensor's tests share."""

from swazure_ros.core.sensor import Sensor


def stochastic(seed=0, sd=0.02, direction_deg=1.0):
    from swazure_ros.core.sensor import SensorNoise

    noise = SensorNoise(
        tracking_cm=(0.0, 10.0, 30.0),
        mean_error=(0.0, 0.01, 0.21),
        detection=(1.0, 1.0, 0.5),
        distance_sd=(sd, sd, sd),
        direction_sd_deg=(direction_deg, direction_deg, direction_deg),
        seed=seed,
    )
    return Sensor(6.0, 8.0, 8.0, 30.0, name="stochastic", noise=noise)
