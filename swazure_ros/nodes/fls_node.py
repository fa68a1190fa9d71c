"""One FLS as an rclpy node: it publishes its camera measurements and answers neighbour queries.

Topics and services, relative to the swarm namespace (``/swarm`` by default):

- ``measurements`` (swazure_interfaces/Measurements), shared by all FLSs:
  each FLS publishes what its camera sees every ``publish_period`` seconds
  (its frame rate), from where it is at that moment;
- ``fls_<id>/get_neighbours`` (swazure_interfaces/GetNeighbours): its blind,
  sweet and decaying neighbours as it knows them;
- ``fls_<id>/compute_pose`` (swazure_interfaces/ComputePose): its pose
  relative to one blind neighbour, found by a discovery run that its process
  asks the coordinator to clock;
- ``radio`` (swazure_interfaces/PathOffer), shared: its path labels, one
  broadcast per round of a discovery run (docs/protocol.md);
- ``estimates`` (swazure_interfaces/PoseEstimates), shared: its estimates
  relative to its targets when a run ends, and each path walk's result.

The radio medium (which FLSs hear a broadcast) and the coordinator's round
clock reach the node through its process's host (:mod:`.host`), which calls
:meth:`FlsNode.on_control`, :meth:`FlsNode.on_offer` and
:meth:`FlsNode.on_walk`.

An FLS keeps its own state: its id, its last measurement and its neighbour
sets. It learns them from its camera and radio, which the simulated world
provides (:class:`Senses`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.context import Context
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.task import Future
from swazure_interfaces.msg import (
    DiscoveryControl,
    Measurements,
    PathOffer,
    PathWalk,
    PoseEstimates,
)
from swazure_interfaces.srv import ComputePose, GetNeighbours

from ..core.discovery import Estimate, FlsRun, LocalView, Offer, bucket_width, sweet_hop
from ..core.errors import SwazureError
from ..core.evaluate import NO_PATH, REASON_BLOCKED, SWEET_PATH
from ..core.observe import NeighbourSets
from ..core.paths import FEWEST_HOPS, SHORTEST_LENGTH
from ..sim.world import Measurement
from .convert import estimates_message, measurements_message, neighbour_fields, offer_message
from .deferred import Reply, create_deferred_service

MEASUREMENTS_TOPIC = "measurements"
NEIGHBOURS_SERVICE = "get_neighbours"
COMPUTE_POSE_SERVICE = "compute_pose"
RADIO_TOPIC = "radio"
ESTIMATES_TOPIC = "estimates"
MEASUREMENTS_QOS = QoSProfile(depth=10)
# A round brings one message from every FLS at once: readers must keep them all.
ROUND_QOS = QoSProfile(
    depth=1, history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE
)
#: DiscoveryControl.POLICY_* -> the core's policy names.
POLICY_NAMES = {
    DiscoveryControl.POLICY_FEWEST_HOPS: FEWEST_HOPS,
    DiscoveryControl.POLICY_SHORTEST_LENGTH: SHORTEST_LENGTH,
}


class ParameterError(SwazureError):
    """A node parameter with a value the node cannot run with."""


class Senses(Protocol):
    """An FLS's camera and radio: what it measures and detects where it is now."""

    def measurement(self, fls_id: int) -> Measurement:
        """The camera's measurements of FLS ``fls_id``."""

    def neighbours(self, fls_id: int) -> NeighbourSets:
        """The neighbours FLS ``fls_id`` knows by radio and camera."""

    def view(self, fls_id: int) -> LocalView:
        """What FLS ``fls_id`` knows of its neighbours, for path discovery."""

    @property
    def sweet_min(self) -> float:
        """Shortest sweet tracking distance of the sensor, cm."""

    @property
    def id_space(self) -> int:
        """One more than the largest FLS id."""


#: How an FLS's process passes a ComputePose request on to the coordinator:
#: a future of the coordinator's response.
AskCoordinator = Callable[[ComputePose.Request], Future]


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
        ask_coordinator: AskCoordinator | None = None,
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
        self._sensed: tuple[Measurement, NeighbourSets] | None = None
        self._publisher = self.create_publisher(Measurements, MEASUREMENTS_TOPIC, MEASUREMENTS_QOS)
        self.create_service(GetNeighbours, f"~/{NEIGHBOURS_SERVICE}", self._on_get_neighbours)
        # The answer waits for a whole discovery run; meanwhile the node keeps serving.
        self._ask_coordinator = ask_coordinator
        create_deferred_service(
            self, ComputePose, f"~/{COMPUTE_POSE_SERVICE}", self._on_compute_pose
        )
        self.create_timer(period, self.publish_measurements)
        self._radio = self.create_publisher(PathOffer, RADIO_TOPIC, ROUND_QOS)
        self._estimates = self.create_publisher(PoseEstimates, ESTIMATES_TOPIC, ROUND_QOS)
        self.runs: dict[int, FlsRun] = {}
        self._first_round: dict[int, int] = {}
        self.messages_sent = 0
        self.bytes_sent = 0

    @property
    def measurement(self) -> Measurement:
        """What the camera measures where the FLS is now."""
        return self._sense()[0]

    @property
    def known_neighbours(self) -> NeighbourSets:
        """The neighbours the FLS knows by radio and camera where it is now."""
        return self._sense()[1]

    def sense(self) -> None:
        """The world changed within this FLS's reach: sense anew when next asked."""
        # Lazily: while a heuristic moves FLSs, revisions come faster than anyone reads.
        self._sensed = None

    def _sense(self) -> tuple[Measurement, NeighbourSets]:
        if self._sensed is None:
            self._sensed = (
                self._senses.measurement(self.fls_id),
                self._senses.neighbours(self.fls_id),
            )
        return self._sensed

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

    def _on_compute_pose(self, request: ComputePose.Request, reply: Reply) -> None:
        if request.source_id != self.fls_id:
            reply(
                ComputePose.Response(
                    success=False,
                    message=f"this is FLS {self.fls_id}; FLS {request.source_id} computes its "
                    f"own poses at {self.get_namespace().rstrip('/')}/"
                    f"{node_name(request.source_id)}/{COMPUTE_POSE_SERVICE} if it exists",
                )
            )
        elif self._ask_coordinator is None:
            reply(
                ComputePose.Response(
                    success=False, message="no coordinator to clock a discovery run"
                )
            )
        else:
            self._ask_coordinator(request).add_done_callback(lambda answer: reply(answer.result()))

    def on_control(self, control: DiscoveryControl, departed: frozenset[int]) -> None:
        """Follow the coordinator's round clock (the host hands every control message on)."""
        if control.command == DiscoveryControl.COMMAND_START:
            run = self.runs.get(control.run_id)
            if run is None:
                run = self.runs[control.run_id] = self._new_run(control)
            run.start(control.phase, departed)
            # Rounds count on across phases and restarts; buckets count from the start.
            self._first_round[control.run_id] = control.round
        elif control.command == DiscoveryControl.COMMAND_ROUND:
            run = self.runs.get(control.run_id)
            if run is not None and run.search is not None:
                run.search.close(np.asarray(control.finished_ids, dtype=np.int64))
                first = self._first_round.get(control.run_id, 0)
                self._broadcast(control, run.search.offer(control.round - first))
        elif control.command == DiscoveryControl.COMMAND_END:
            run = self.runs.pop(control.run_id, None)
            self._first_round.pop(control.run_id, None)
            if run is not None and run.targets is not None:
                stamp = self.get_clock().now().to_msg()
                self._publish(
                    self._estimates,
                    estimates_message(control.run_id, self.fls_id, run.estimates(), stamp),
                )

    def on_offer(self, run_id: int, sender: int, offer: Offer) -> None:
        """Hear a neighbour's broadcast of the current phase of run ``run_id``."""
        run = self.runs.get(run_id)
        if run is not None and run.search is not None:
            run.search.hear(sender, offer)

    def on_walk(self, walk: PathWalk) -> PathWalk | None:
        """Take a path walk addressed to this FLS; return the walk to send on, if any."""
        path = [int(fls) for fls in walk.path]
        if walk.state == PathWalk.STATE_WALKING:
            if walk.hop + 1 >= len(path):
                # The target: back to the source (blind neighbours are within radio range).
                walk.state, walk.hop = PathWalk.STATE_ARRIVED, 0
                return walk
            seen = self.measurement
            hop = sweet_hop(
                seen.target_ids, seen.range_class, seen.vector, seen.tracking, path[walk.hop + 1]
            )
            if hop is None:
                walk.state, walk.hop = PathWalk.STATE_FAILED, 0
                return walk
            # Summed from the source outwards, as the core engine sums.
            walk.vector.x += hop[0][0]
            walk.vector.y += hop[0][1]
            walk.vector.z += hop[0][2]
            walk.hop += 1
            return walk
        arrived = walk.state == PathWalk.STATE_ARRIVED
        found = Estimate(
            int(walk.target_id),
            SWEET_PATH if arrived else NO_PATH,
            REASON_BLOCKED,
            tuple(path) if arrived else (),
            vector=np.array([walk.vector.x, walk.vector.y, walk.vector.z])
            if arrived
            else np.full(3, np.nan),
            radio_path=tuple(path),
        )
        stamp = self.get_clock().now().to_msg()
        self._publish(self._estimates, estimates_message(walk.run_id, self.fls_id, [found], stamp))
        return None

    def _new_run(self, control: DiscoveryControl) -> FlsRun:
        view = self._senses.view(self.fls_id)
        targets: np.ndarray | None = view.blind
        if len(control.source_ids):
            sources = np.asarray(control.source_ids, dtype=np.int64)
            mine = sources == self.fls_id
            if not mine.any():
                targets = None
            elif len(control.target_ids):
                # On demand, a source answers for its blind neighbours only.
                asked = np.asarray(control.target_ids, dtype=np.int64)[mine]
                targets = asked[np.isin(asked, view.blind)]
        policy = POLICY_NAMES[control.policy]
        width = bucket_width(self._senses.sweet_min, policy)
        return FlsRun(view, policy, width, self._senses.id_space, targets)

    def _broadcast(self, control: DiscoveryControl, offer: Offer) -> None:
        stamp = self.get_clock().now().to_msg()
        message = offer_message(
            control.run_id, control.phase, control.round, self.fls_id, offer, stamp
        )
        self._publish(self._radio, message)

    def _publish(self, publisher: object, message: object) -> None:
        # Serialised once here, so that the bytes on the wire are counted exactly.
        data = serialize_message(message)
        self.messages_sent += 1
        self.bytes_sent += len(data)
        publisher.publish(data)  # type: ignore[attr-defined]
