"""One FLS as an rclpy node: it publishes its camera measurements and answers neighbour queries.

Topics and services, relative to the swarm namespace (``/swarm`` by default):

- ``measurements`` (swazure_interfaces/Measurements), shared by all FLSs:
  each FLS publishes every ``publish_period`` seconds, and at once after it
  senses anew (when the world changes);
- ``fls_<id>/get_neighbours`` (swazure_interfaces/GetNeighbours): its blind,
  sweet and decaying neighbours as it knows them.

An FLS keeps its own state: its id, its last measurement and its neighbour
sets. It learns them from its camera and radio, which the simulated world
provides (:class:`Senses`).
"""

from __future__ import annotations

from typing import Protocol

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from swazure_interfaces.msg import Measurements
from swazure_interfaces.srv import GetNeighbours

from ..core.errors import SwazureError
from ..core.observe import NeighbourSets
from ..sim.world import Measurement
from .convert import measurements_message, neighbour_fields

MEASUREMENTS_TOPIC = "measurements"
NEIGHBOURS_SERVICE = "get_neighbours"
MEASUREMENTS_QOS = QoSProfile(depth=10)


class ParameterError(SwazureError):
    """A node parameter with a value the node cannot run with."""


class Senses(Protocol):
    """An FLS's camera and radio: what it measures and detects where it is now."""

    def measurement(self, fls_id: int) -> Measurement:
        """The camera's measurements of FLS ``fls_id``."""

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """The neighbours FLS ``fls_id`` knows by radio and camera."""


def node_name(fls_id: int) -> str:
    """The node name of FLS ``fls_id``."""
    return f"fls_{fls_id}"


class FlsNode(Node):
    """One Flying Light Speck."""

    def __init__(
        self,
        fls_id: int,
        senses: Senses,
        *,
        namespace: str = "swarm",
        context: Context | None = None,
    ) -> None:
        super().__init__(
            node_name(fls_id),
            namespace=namespace,
            context=context,
            # Each endpoint costs discovery time in swarms of thousands of nodes:
            # no rosout publisher, no parameter services.
            enable_rosout=False,
            start_parameter_services=False,
        )
        self.fls_id = fls_id
        self._senses = senses
        try:
            period = self.declare_parameter(
                "publish_period",
                1.0,
                ParameterDescriptor(description="seconds between measurement messages"),
            ).value
        except ParameterException as err:
            raise ParameterError(f"{self.get_fully_qualified_name()}: {err}") from err
        if not isinstance(period, float) or not period > 0:
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: parameter publish_period must be "
                f"a positive number of seconds, got {period!r}"
            )
        self.publish_period = period
        self.measurement = senses.measurement(fls_id)
        self.known_neighbours = senses.neighbours(fls_id)
        self._publisher = self.create_publisher(Measurements, MEASUREMENTS_TOPIC, MEASUREMENTS_QOS)
        self.create_service(GetNeighbours, f"~/{NEIGHBOURS_SERVICE}", self._on_get_neighbours)
        self.create_timer(period, self.publish_measurements)

    def sense(self) -> None:
        """Take new measurements (the world changed) and publish them at once."""
        self.measurement = self._senses.measurement(self.fls_id)
        self.known_neighbours = self._senses.neighbours(self.fls_id)
        self.publish_measurements()

    def publish_measurements(self) -> None:
        """Publish the last measurements on the shared topic."""
        stamp = self.get_clock().now().to_msg()
        self._publisher.publish(measurements_message(self.fls_id, self.measurement, stamp))

    def _on_get_neighbours(
        self, request: GetNeighbours.Request, response: GetNeighbours.Response
    ) -> GetNeighbours.Response:
        if request.fls_id != self.fls_id:
            response.success = False
            response.message = (
                f"this is FLS {self.fls_id}; FLS {request.fls_id} answers for itself at "
                f"{self.get_namespace().rstrip('/')}/{node_name(request.fls_id)}/"
                f"{NEIGHBOURS_SERVICE} if it exists"
            )
            return response
        for field, ids in neighbour_fields(self.known_neighbours).items():
            setattr(response, field, ids)
        response.success = True
        return response
