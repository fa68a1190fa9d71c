"""A swarm's description: what every FLS and process of a swarm is given.

A display's shape is common knowledge of its FLSs: the cloud of points, how
it is scaled, the FLSs' radius (or beta), the sensor they measure with and
the seed of the collision removal. From these alone every FLS knows its
assigned point and its neighbours' (:meth:`SwarmDescription.assigned`);
the simulator builds its ground truth from the same description.

A description may ask for its cloud resampled (``resample``: that many
points at the cloud's own spacing, seeded by ``seed``). The launcher
resamples once and writes the result (:meth:`SwarmDescription.written`);
every other process then reads that file instead of resampling again.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Self

import numpy as np
from numpy.typing import NDArray

from ..core.clouds import Cloud
from ..core.geometry import Swarm, make_swarm
from ..core.sensor import Sensor
from .cloud_files import load_cloud, read_resampled, resampled_cloud, write_cloud
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
    resample: int | None = None  # the cloud resampled to this many points (--resample)
    resampled_file: str | None = None  # where the resampled cloud is written, once it is

    def cloud_of(self) -> Cloud:
        """The swarm's cloud, in cm: resampled when asked, read from its file once written.

        Raises
        ------
        CloudError
            The cloud cannot be read or resampled, or its written file holds
            another number of points.
        """
        cloud = load_cloud(self.cloud, self.scale)
        if self.resample is None:
            return cloud
        if self.resampled_file is None:
            return resampled_cloud(cloud, self.resample, self.seed)
        # Written by the launcher (exactly: cloud_files.write_cloud): read, not resampled again.
        return read_resampled(cloud, self.resample, self.seed, Path(self.resampled_file))

    def written(self, folder: Path) -> Self:
        """This description with its resampled cloud written into ``folder`` (unchanged
        without ``resample``): every process that builds it then reads the file."""
        if self.resample is None:
            return self
        return replace(self, resampled_file=str(write_cloud(folder, self.cloud_of())))

    def sensor(self) -> Sensor:
        """The sensor every FLS measures with (error-free if ``accurate``)."""
        sensor = load_sensor(Path(self.sensor_file) if self.sensor_file else None)
        return sensor.error_free() if self.accurate else sensor

    def assigned(self) -> Swarm:
        """The FLSs at their assigned points (cm), colliding ones removed."""
        cloud = self.cloud_of()
        return make_swarm(cloud.points, beta=self.beta, radius=self.radius, seed=self.seed)

    def fls_ids(self) -> NDArray[np.int64]:
        """(N,) the ids of the swarm's FLSs, without sensing anything."""
        return self.assigned().cloud_index
