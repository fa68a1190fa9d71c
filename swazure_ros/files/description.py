"""A swarm's description: what every FLS and process of a swarm is given.

A display's shape is common knowledge of its FLSs: the cloud of points, how
it is scaled, the FLSs' radius (or beta), the sensor they measure with and
the seed of the collision removal. From these alone every FLS knows its
assigned point and its neighbours' (:meth:`SwarmDescription.assigned`);
the simulator builds its ground truth from the same description.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..core.geometry import Swarm, make_swarm
from ..core.sensor import Sensor
from .cloud_files import load_cloud
from .sensors import load_sensor

#: The cloud of a swarm whose options name none (``--cloud``'s default, a swarm file's).
DEFAULT_CLOUD = "torus"


@dataclass(frozen=True)
class SwarmDescription:
    """Everything that determines a swarm's assigned points and its sensor."""

    cloud: str
    scale: float | None = None
    beta: float | None = None
    radius: float | None = None
    sensor_file: str | None = None
    accurate: bool = False
    seed: int = 0

    def sensor(self) -> Sensor:
        """The sensor every FLS measures with (error-free if ``accurate``)."""
        sensor = load_sensor(Path(self.sensor_file) if self.sensor_file else None)
        return sensor.error_free() if self.accurate else sensor

    def assigned(self) -> Swarm:
        """The FLSs at their assigned points (cm), colliding ones removed."""
        cloud = load_cloud(self.cloud, self.scale)
        return make_swarm(cloud.points, beta=self.beta, radius=self.radius, seed=self.seed)

    def fls_ids(self) -> NDArray[np.int64]:
        """(N,) the ids of the swarm's FLSs, without sensing anything."""
        return self.assigned().cloud_index
