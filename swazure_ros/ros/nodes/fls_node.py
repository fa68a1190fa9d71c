"""One FLS as an rclpy node: its camera and radio, and its part of discovery and tracking.

Topics and services, relative to the swarm namespace (``/swarm`` by default;
names and QoS in :mod:`.names`):

- ``measurements`` (swazure_interfaces/Measurements), shared by all FLSs:
  each FLS looks every ``publish_period`` seconds (its frame rate) and
  publishes what its camera sees when that changed, or every
  ``republish_period`` seconds if set; the last message of each FLS is
  latched for readers who come later;
- ``fls_<id>/get_neighbours`` (swazure_interfaces/GetNeighbours): its blind,
  sweet and decaying neighbours as it knows them, where it offers the service
  (:meth:`FlsNode.offer_neighbours_service`); its process's host node answers
  for it too (``host_<k>/get_neighbours``, :meth:`FlsNode.answer_neighbours`);
- ``radio/<band>/c<i>_<j>_<k>`` (its radio cell's, through its process's
  radio) and ``estimates``, shared: its path labels, one broadcast per round
  of a discovery run, and its estimates when a run ends or a path walk comes
  back (docs/protocol.md);
- ``fls_<id>/camera/image_raw`` and ``fls_<id>/camera/camera_info``
  (sensor_msgs/Image, CameraInfo), only when the ``camera_view`` parameter
  names a neighbour: each frame, what the FLS's rendering camera sees aimed
  at that neighbour's marker (docs/camera.md), to look through its eyes;
- ``fls_<id>/track`` (swazure_interfaces/TrackTarget): track a target's motion
  through a relay (spec, section 9); relays stream ``track_samples``, the
  source publishes ``track_estimates``. Both run on the node's clock,
  simulated time with ``use_sim_time``.

The algorithms are the protocol's state machines, one per idea: the node
is a :class:`~swazure_ros.protocol.discovery.participant.Participant` of
discovery, and tracks and relays through :class:`~.fls_tracking.FlsTracking`.
Each callback converts a message, makes one call into a machine, and
publishes what comes out.

The node subscribes to none of the shared topics itself: its process's
:class:`~.radio.Radio` hears each of them once and hands a message to the FLS
nodes it reaches (:meth:`FlsNode.on_control` with the round's offers,
:meth:`~FlsNode.on_walk`, and its :class:`~.fls_tracking.FlsTracking`'s
``on_request`` and ``on_sample``), as a radio would. A thousand subscriptions
per topic would cost discovery time and deliver every message a thousand times.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial

import numpy as np
from builtin_interfaces.msg import Time
from rclpy.context import Context
from rclpy.event_handler import PublisherEventCallbacks, QoSPublisherMatchedInfo
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.timer import Timer
from swazure_interfaces.msg import Measurements, PoseEstimates
from swazure_interfaces.srv import GetNeighbours

from ...core.fit import PATH
from ...core.observe import Measurement, NeighbourSets
from ...core.relay import RelaySenses
from ...protocol.discovery.messages import START, Broadcast, Control, Report, RoundOffers
from ...protocol.discovery.participant import Participant
from ...protocol.moves import WALKING, Walk, next_hop, step_walk, walk_estimate
from ...protocol.readings import ReadingsBook
from ...protocol.senses import DetectedSenses, Senses
from ..convert.discovery import estimates_fields
from ..convert.measurements import measurements_bytes
from ..convert.sensing import neighbour_fields
from ..plumbing.names import (
    ESTIMATES_TOPIC,
    MEASUREMENTS_QOS,
    MEASUREMENTS_TOPIC,
    NEIGHBOURS_SERVICE,
    ROUND_QOS,
    node_name,
)
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterError
from ..plumbing.shared_timers import SharedTimer, SharedTimers
from ..security.auth import SwarmKey
from ..security.records import record_writer
from . import fls_parameters, fls_tracking
from .fls_camera import CameraView, DetectedSensing, Eyes
from .fls_parameters import PUBLISH_PERIOD, REPUBLISH_PERIOD
from .fls_tracking import FlsTracking


class Transmitter:
    """The transmitter of a process's FLSs: their offers go out by its radio, their reports here.

    Every FLS sends its offers and estimates through its process's
    transmitter, as it hears through its process's radio (:class:`~.radio.Radio`,
    which sends the offers on its FLSs' radio cells): a thousand FLS nodes then
    add a few publishers, not thousands, to the swarm's graph. Messages are
    serialised once, so that the bytes on the wire are counted exactly.
    """

    def __init__(self, node: Node, key: SwarmKey | None = None) -> None:
        self._node = node
        self.key = key or SwarmKey()
        self._estimates = node.create_publisher(PoseEstimates, ESTIMATES_TOPIC, ROUND_QOS)

    def readers(self) -> int:
        """Readers matched to the estimates (the coordinator's): who would hear a report now."""
        return self._estimates.get_subscription_count()

    def send(self, out: Report) -> int:
        """Send a report on ``estimates``; the bytes sent."""
        stamp = self._node.get_clock().now().to_msg()
        data = _ESTIMATES_BYTES(estimates_fields(out, stamp), self.key.auth)
        self._estimates.publish(data)
        return len(data)


@dataclass(frozen=True)
class RadioLink:
    """How an FLS node reaches the swarm's radio: its process's transmitter, and the book of
    what that radio heard of the FLSs' cameras; None: its own (signing with ``key``).

    ``timers``: what its frames run on, its process's one timer for all its FLS nodes
    (:mod:`..plumbing.shared_timers`); None: a timer of its own.
    """

    transmitter: Transmitter | None = None
    readings: ReadingsBook | None = None
    key: SwarmKey | None = None
    timers: SharedTimers | None = None


#: A report's bytes from its fields (:mod:`..security.records`): a Move's walk ends in one.
_ESTIMATES_BYTES = record_writer(PoseEstimates)
#: The parameters every FLS node declares, besides its tracking's (FlsTracking's).
PARAMETERS = fls_parameters.NODE


class FlsNode(SwarmNode):
    """One Flying Light Speck.

    It knows the world only through ``senses`` (:class:`~..protocol.senses.Senses`):
    the simulator's in packed mode, or its own camera's detections. Its parts:
    its camera's (``camera``: :class:`~.fls_camera.CameraView` of simulated
    ``Eyes``, for ``camera_view``; or :class:`~.fls_camera.DetectedSensing` of
    ``DetectedSenses``), its radio's (:class:`Transmitter` and discovery's
    :class:`~..protocol.discovery.participant.Participant`, through ``link``)
    and its tracking's (:class:`~.fls_tracking.FlsTracking`: ``relay_senses``
    chooses relays and takes relayed samples, where the senses can).
    It answers ``~/get_neighbours`` once :meth:`offer_neighbours_service` is
    called; its host may answer for it instead (:meth:`answer_neighbours`): a
    service's two endpoints are what a process's bring-up grows with, as the
    square of their number (docs/swarm.md).
    """

    def __init__(
        self,
        fls_id: int,
        senses: Senses,
        *,
        namespace: str = "swarm",
        context: Context | None = None,
        link: RadioLink | None = None,
        camera: Eyes | DetectedSenses | None = None,
        relay_senses: Callable[[], RelaySenses] | None = None,
        parameter_overrides: list[Parameter] | None = None,
        parameter_services: bool = False,
        parameter_events: Publisher | None = None,
    ) -> None:
        super().__init__(
            node_name(fls_id),
            namespace=namespace,
            context=context,
            parameter_overrides=parameter_overrides,
            parameter_services=parameter_services,
            parameter_events=parameter_events,
        )
        self.fls_id = fls_id
        self._senses = senses
        link = link or RadioLink()
        # Its parameters and its tracking's at once: one ParameterEvent (declare_all).
        self.publish_period, self.republish_period, camera_view, *tracking = self.declare_all(
            (*PARAMETERS, *fls_tracking.PARAMETERS),
            {
                PUBLISH_PERIOD.name: self._set_publish_period,
                REPUBLISH_PERIOD.name: partial(setattr, self, "republish_period"),
            },
        )
        # Its track service, the streams it relays and the targets it tracks.
        self.tracking = FlsTracking(
            self, fls_id, relay_senses, self.publish, self.elsewhere, tracking
        )
        #: What its camera shows a person (camera_view), if anything.
        self.view = self._camera_view(camera, camera_view)
        # (world revision, what the FLS senses in it)
        self._sensed: tuple[int, Measurement, NeighbourSets] | None = None
        self._published: Measurement | None = None  # the last measurement sent
        self._published_at = 0  # ns on the node's clock
        # What its process's radio heard of other FLSs' cameras (a fitting run's window).
        self.discovery = Participant(
            fls_id,
            lambda: senses.view(fls_id),
            senses.sensor,
            senses.radius,
            senses.id_space,
            link.readings,
            lambda: senses.near_view(fls_id),  # the decaying rows when a run needs them
        )
        self._publisher = self.create_publisher(
            Measurements,
            MEASUREMENTS_TOPIC,
            MEASUREMENTS_QOS,
            event_callbacks=PublisherEventCallbacks(matched=self._on_reader_matched),
        )
        # Frames run only while there may be something to send: at rest, thousands
        # of FLSs would otherwise wake a process thousands of times a second.
        self._frames: Timer | SharedTimer = (
            self.create_timer(self.publish_period, self._on_frame)
            if link.timers is None
            else link.timers.create_timer(self.publish_period, self.guarded(self._on_frame))
        )
        self._frames_stopped = False
        #: Its own camera's readings and move commands, when it senses by them.
        self.detected = (
            DetectedSensing(self, fls_id, camera, link.key, self._sensed_anew)
            if isinstance(camera, DetectedSenses)
            else None
        )
        # Alone (no process hosting it), an FLS transmits with publishers of its own.
        self.transmitter = link.transmitter or Transmitter(self, link.key)
        self.messages_sent = 0
        self.measurements_sent = 0  # Measurements messages published
        self.frames_taken = 0  # frame timer callbacks run
        self.bytes_sent = 0

    def _set_publish_period(self, seconds: float) -> None:
        """Take a new frame period at once (``ros2 param set``)."""
        self.publish_period = seconds
        self._frames.timer_period_ns = round(seconds * 1e9)
        if self.view is not None:
            self.view.set_period(seconds)

    def _camera_view(self, camera: Eyes | DetectedSenses | None, value: int) -> CameraView | None:
        """The camera_view part, made if the parameter (``value``) names a neighbour."""
        if value < 0:
            return None
        if value == self.fls_id:
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: camera_view names this FLS itself"
            )
        if camera is None or isinstance(camera, DetectedSenses):
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: camera_view needs the simulated "
                "camera (an FLS of `swazure spawn`); this FLS's senses cannot render"
            )
        if value not in self._senses.ids:
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: camera_view: no FLS {value} "
                f"in this swarm of {len(self._senses.ids)} FLSs"
            )
        return CameraView(self, self.fls_id, camera, int(value), self.publish_period)

    def _sensed_anew(self) -> None:
        """What it senses changed (its camera's detections, a move): take a frame soon."""
        self._sensed = None
        self.sense()

    # Camera and radio --------------------------------------------------------

    @property
    def measurement(self) -> Measurement:
        """What the camera measures where the FLS is now."""
        return self._sense()[0]

    @property
    def known_neighbours(self) -> NeighbourSets:
        """The neighbours the FLS knows by radio and camera where it is now."""
        return self._sense()[1]

    def sense(self) -> None:
        """The world changed within this FLS's reach: take a frame soon."""
        self._wake_frames()

    def _wake_frames(self) -> None:
        if self._frames_stopped:
            self._frames_stopped = False
            self._frames.reset()

    def destroy_node(self) -> None:
        """Node's; its frames stop too, which its process's timer may run (``RadioLink``)."""
        self._frames.cancel()
        super().destroy_node()  # type: ignore[no-untyped-call]

    def _stop_frames(self) -> None:
        self._frames_stopped = True
        self._frames.cancel()

    def _on_reader_matched(self, info: QoSPublisherMatchedInfo) -> None:
        if info.current_count_change > 0:
            self._wake_frames()

    def _sense(self) -> tuple[Measurement, NeighbourSets]:
        # Lazily, once per revision: while a heuristic moves FLSs, revisions come
        # faster than anyone reads.
        revision = self._senses.revision
        if self._sensed is None or self._sensed[0] != revision:
            self._sensed = (
                revision,
                self._senses.measurement(self.fls_id),
                self._senses.neighbours(self.fls_id),
            )
        return self._sensed[1:]

    def _on_frame(self) -> None:
        self.frames_taken += 1
        if self._publisher.get_subscription_count() == 0:
            # Nobody reads: build nothing (a heuristic's revisions change what most FLSs
            # see many times a second). A reader that comes gets this FLS's last message
            # at once (latched) and the current one at the next frame.
            self._published = None
            self._stop_frames()  # until a reader comes or the world changes
            return
        now = self.get_clock().now()
        seen = self.measurement
        due = self.republish_period > 0 and (
            now.nanoseconds - self._published_at >= round(self.republish_period * 1e9)
        )
        if due or self._published is None or not seen.same_as(self._published):
            self.publish_measurements(now.to_msg())
        elif self.republish_period == 0:
            self._stop_frames()  # sent and unchanged: nothing to do until it changes

    def publish_measurements(self, stamp: Time | None = None) -> None:
        """Publish what the camera measures now on the shared topic."""
        if stamp is None:
            stamp = self.get_clock().now().to_msg()
        self._published = self.measurement
        self._published_at = self.get_clock().now().nanoseconds
        self.measurements_sent += 1
        # Each reading's radio distance: what a source's fit weighs the reading by.
        view = self._senses.view(self.fls_id)
        rows = np.searchsorted(view.other, self._published.target_ids)
        key, radio = self.transmitter.key, view.distance[rows]
        self._publisher.publish(
            measurements_bytes(self.fls_id, self._published, stamp, key, radio)
        )

    def offer_neighbours_service(self) -> None:
        """Answer ``~/get_neighbours`` (swazure_interfaces/GetNeighbours) for itself."""
        self.create_service(GetNeighbours, f"~/{NEIGHBOURS_SERVICE}", self._on_get_neighbours)

    def elsewhere(self, fls_id: int, service: str, does: str = "answers for itself") -> str:
        """Where FLS ``fls_id`` answers ``service`` for itself."""
        return (
            f"this is FLS {self.fls_id}; FLS {fls_id} {does} at "
            f"{self.get_namespace().rstrip('/')}/{node_name(fls_id)}/{service} if it exists"
        )

    def _on_get_neighbours(
        self, request: GetNeighbours.Request, response: GetNeighbours.Response
    ) -> GetNeighbours.Response:
        if request.fls_id not in (GetNeighbours.Request.THIS_FLS, self.fls_id):
            response.success = False
            response.message = (
                self.elsewhere(request.fls_id, NEIGHBOURS_SERVICE)
                if request.fls_id >= 0
                else f"fls_id {request.fls_id}: an FLS id, or THIS_FLS (-1, the default)"
            )
            return response
        return self.answer_neighbours(response)

    def answer_neighbours(self, response: GetNeighbours.Response) -> GetNeighbours.Response:
        """``response`` filled with this FLS's neighbours as it knows them, and success."""
        known = self.known_neighbours
        for name, ids in neighbour_fields(known).items():
            setattr(response, name, ids)
        every = np.concatenate([known.blind, known.sweet, known.visible_decaying])
        response.gone_ids = sorted(set(every.tolist()) & self._senses.gone)
        response.success = True
        return response

    # Discovery ---------------------------------------------------------------

    def on_control(self, control: Control, heard: RoundOffers | None) -> Broadcast | None:
        """Follow the round clock, taking the offers heard since the last control.

        A report is sent here; an offer is returned for the process's radio,
        which sends its FLSs' offers of a round together (:meth:`count_sent`).
        """
        if control.command == START and control.estimator != PATH and self._published is None:
            # The sources of a fitting run read this FLS's measurement (its radio has just
            # subscribed): sent now, latched, not a frame period later.
            self.publish_measurements()
        out = self.discovery.on_control(control, heard)
        if isinstance(out, Report):
            self._publish_discovery(out)
            return None
        return out

    def count_sent(self, size: int) -> None:
        """Count an offer of this FLS's that its radio sent (``size`` bytes)."""
        self.bytes_sent += size
        self.messages_sent += 1

    def report_waiting(self, at_deadline: bool = False) -> bool:
        """Report the fits whose windows are heard (all ``at_deadline``); True when none wait."""
        for report in self.discovery.waiting_reports(at_deadline):
            self._publish_discovery(report)
        return not self.discovery.waiting

    def on_walk(self, walk: Walk, seen: Measurement | None = None) -> Walk | None:
        """Take a path walk addressed to this FLS; return the walk to send on, if any.

        ``seen``: this FLS's measurement of the walk's next hop, when its process read the
        hops of its FLSs at once (``Senses.hop_measurements``); read here otherwise.
        """
        if walk.state == WALKING:
            ahead = next_hop(walk)
            if seen is None and ahead:  # the target has no hop to measure: it turns back
                seen = self._senses.measurement(self.fls_id, ahead)
            return step_walk(walk, seen)
        # Back at the source: its result.
        self._publish_discovery(Report(walk.run_id, self.fls_id, [walk_estimate(walk)]))
        return None

    def abandon_runs(self) -> int:
        """Drop every discovery run; as a source, report its targets ABORTED. The count."""
        reports = self.discovery.abandon()
        for report in reports:
            self._publish_discovery(report)
        return sum(len(report.estimates) for report in reports)

    def _publish_discovery(self, out: Report) -> None:
        self.count_sent(self.transmitter.send(out))

    def publish(self, publisher: Publisher, message: object) -> None:
        """Sign, serialise and publish ``message``, counting the bytes sent."""
        # Serialised once here, so that the bytes on the wire are counted exactly.
        data = self.transmitter.key.serialize(message)
        self.messages_sent += 1
        self.bytes_sent += len(data)
        publisher.publish(data)
