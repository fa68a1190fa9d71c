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
  relative to its targets when a run ends, and each path walk's result;
- ``fls_<id>/track`` (swazure_interfaces/TrackTarget): track a target's motion
  through a relay (spec, section 9); the relay streams samples on
  ``track_samples`` and the source publishes on ``track_estimates``
  (swazure_interfaces/TrackEstimate), shared, one estimate per sample, until
  the stream ends or times out. Both run on the node's clock, simulated time
  with ``use_sim_time``.

The radio medium (which FLSs hear a broadcast) and the coordinator's round
clock reach the node through its process's host (:mod:`.host`), which calls
:meth:`FlsNode.on_control`, :meth:`FlsNode.on_offer` and
:meth:`FlsNode.on_walk`, and the track requests and samples addressed to it
(:meth:`FlsNode.on_track_request`, :meth:`FlsNode.on_track_sample`).

An FLS keeps its own state: its id, its last measurement and its neighbour
sets. It learns them from its camera and radio, which the simulated world
provides (:class:`Senses`).
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import JumpThreshold
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rclpy.task import Future
from rclpy.time import Time
from swazure_interfaces.msg import (
    DiscoveryControl,
    Measurements,
    PathOffer,
    PathWalk,
    PoseEstimates,
    TrackEstimate,
    TrackRequest,
    TrackSample,
)
from swazure_interfaces.srv import ComputePose, GetNeighbours, TrackTarget

from ..core.discovery import Estimate, FlsRun, LocalView, Offer, bucket_width, sweet_hop
from ..core.errors import SwazureError, UnknownFlsError
from ..core.evaluate import NO_PATH, REASON_BLOCKED, SWEET_PATH
from ..core.observe import NeighbourSets
from ..core.paths import FEWEST_HOPS, SHORTEST_LENGTH
from ..core.tracking import (
    ENDED,
    RELAY_MESSAGES,
    RELAY_OK,
    TIMED_OUT,
    TRACK_SETTINGS,
    Track,
    TrackConfig,
    TrackingError,
    arrival,
    nanoseconds,
)
from ..sim.world import Measurement
from .convert import (
    TRACK_MODELS,
    array3,
    estimates_message,
    measurements_message,
    neighbour_fields,
    offer_message,
    to_seconds,
    to_stamp,
    track_estimate_message,
    vector3,
)
from .deferred import Reply, create_deferred_service

MEASUREMENTS_TOPIC = "measurements"
NEIGHBOURS_SERVICE = "get_neighbours"
COMPUTE_POSE_SERVICE = "compute_pose"
RADIO_TOPIC = "radio"
ESTIMATES_TOPIC = "estimates"
TRACK_SERVICE = "track"
TRACK_REQUESTS_TOPIC = "track_requests"
TRACK_SAMPLES_TOPIC = "track_samples"
TRACK_ESTIMATES_TOPIC = "track_estimates"
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

#: TrackTarget.MODEL_* (the same numbers as TrackEstimate's) -> the core's filter models.
MODEL_NAMES = {code: name for name, code in TRACK_MODELS.items()}


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

    def choose_relay(self, source: int, target: int, seconds: float) -> int | None:
        """The relay for ``source`` to track ``target`` at time ``seconds``, or None."""

    def next_relay(self, source: int, target: int, relay: int, seconds: float) -> int | None:
        """The relay to hand ``relay``'s stream over to at time ``seconds``, or None."""

    def track_sample(
        self, source: int, relay: int, target: int, seconds: float
    ) -> tuple[int, np.ndarray]:
        """(RELAY_* status, (3,) cm) of the sample ``relay`` senses for ``source``."""


#: How an FLS's process passes a ComputePose request on to the coordinator:
#: a future of the coordinator's response.
AskCoordinator = Callable[[ComputePose.Request], Future]


@dataclass
class Relayed:
    """A stream this FLS relays: the next frame, and samples waiting out their delay."""

    source: int
    target: int
    next_frame: int  # ns
    outbox: deque[tuple[int, TrackSample]] = field(default_factory=deque)  # (release ns, sample)
    ended: bool = False


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
        parameter_overrides: list[Parameter] | None = None,
    ) -> None:
        super().__init__(
            node_name(fls_id),
            namespace=namespace,
            context=context,
            parameter_overrides=parameter_overrides,
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
        self.track_config = self._declare_track_config()
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
        self.create_service(TrackTarget, f"~/{TRACK_SERVICE}", self._on_track)
        # Created at the first track: most FLSs never relay nor track, and
        # every endpoint costs discovery time.
        self._track_publishers: dict[str, object] = {}
        # Relay frames and track timeouts run on the node's clock. On simulated
        # time they follow /clock itself: the EventsExecutor's timers do not
        # support a simulated clock (ros2/rclcpp#2457) and skip periods.
        self._track_ticks: object | None = None
        self.relayed: dict[tuple[int, int], Relayed] = {}
        self.tracks: dict[int, Track] = {}  # target id -> its stream
        # Sent and heard, so that whoever drives a simulated clock knows when all is delivered.
        self.track_traffic: Counter[str] = Counter()
        self.runs: dict[int, FlsRun] = {}
        self._first_round: dict[int, int] = {}
        self.messages_sent = 0
        self.bytes_sent = 0

    def _declare_track_config(self) -> TrackConfig:
        defaults = TrackConfig()
        values = {}
        try:
            # track.<name>, defaulting to TrackConfig's.
            for name, description in TRACK_SETTINGS.items():
                values[name] = self.declare_parameter(
                    f"track.{name}",
                    getattr(defaults, name),
                    ParameterDescriptor(description=description),
                ).value
            return TrackConfig(**values)
        except (ParameterException, TrackingError) as err:
            raise ParameterError(f"{self.get_fully_qualified_name()}: {err}") from err

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
        for name, ids in neighbour_fields(self.known_neighbours).items():
            setattr(response, name, ids)
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

    def _now(self) -> int:
        return self.get_clock().now().nanoseconds

    def _on_track(
        self, request: TrackTarget.Request, response: TrackTarget.Response
    ) -> TrackTarget.Response:
        response.success = False
        if request.source_id != self.fls_id:
            response.message = (
                f"this is FLS {self.fls_id}; FLS {request.source_id} tracks from its own "
                f"{node_name(request.source_id)}/{TRACK_SERVICE}"
            )
            return response
        model = MODEL_NAMES.get(request.model)
        if model is None:
            response.message = f"unknown model {request.model}: use TrackTarget.MODEL_*"
            return response
        target, now = int(request.target_id), self._now()
        try:
            relay = self._senses.choose_relay(self.fls_id, target, now / 1e9)
        except UnknownFlsError as err:
            response.message = str(err)
            return response
        if relay is None or target == self.fls_id:
            response.message = f"no sweet neighbour of FLS {self.fls_id} sees FLS {target}"
            return response
        if target in self.tracks:
            self._request(TrackRequest.COMMAND_STOP, self.tracks[target].relay, target, now)
        config = replace(self.track_config, model=model)
        self.tracks[target] = Track(config.tracker(), config.timeout, relay)
        self._request(TrackRequest.COMMAND_START, relay, target, now)
        self._start_track_ticks()
        response.success, response.relay_id = True, relay
        response.message = f"tracking FLS {target} through FLS {relay}"
        return response

    def _track_publisher(self, message_type: type, topic: str) -> object:
        if topic not in self._track_publishers:
            self._track_publishers[topic] = self.create_publisher(message_type, topic, ROUND_QOS)
        return self._track_publishers[topic]

    def _request(self, command: int, relay: int, target: int, start: int) -> None:
        request = TrackRequest(
            command=command, source_id=self.fls_id, relay_id=relay, target_id=target
        )
        # The relay's first frame: the moment the source asks, whenever the request lands.
        request.header.stamp = Time(nanoseconds=start).to_msg()
        self._publish(self._track_publisher(TrackRequest, TRACK_REQUESTS_TOPIC), request)
        self.track_traffic["requests_sent"] += 1

    def on_track_request(self, request: TrackRequest) -> None:
        """Start or stop relaying a target to a source (the host hands requests to the relay)."""
        self.track_traffic["requests_heard"] += 1
        key = (int(request.source_id), int(request.target_id))
        if request.command == TrackRequest.COMMAND_STOP:
            self.relayed.pop(key, None)
            return
        # The first frame is the request's moment; the next come every frame period.
        start = Time.from_msg(request.header.stamp).nanoseconds
        self.relayed[key] = Relayed(*key, next_frame=start)
        self._start_track_ticks()
        self._relay_frames()

    def _start_track_ticks(self) -> None:
        if self._track_ticks is not None:
            return
        if self.get_parameter("use_sim_time").value:
            self._track_ticks = self.get_clock().create_jump_callback(
                JumpThreshold(min_forward=Duration(nanoseconds=1), min_backward=None),
                post_callback=lambda jump: self._on_track_tick(),
            )
        else:
            self._track_ticks = self.create_timer(
                self.track_config.frame_period, self._on_track_tick
            )

    def _on_track_tick(self) -> None:
        self._relay_frames()
        self._check_tracks()

    def _relay_frames(self) -> None:
        now, period = self._now(), nanoseconds(self.track_config.frame_period)
        delay = nanoseconds(self.track_config.delay)
        publisher = self._track_publisher(TrackSample, TRACK_SAMPLES_TOPIC)
        for key, stream in list(self.relayed.items()):
            # Frame by frame at their own times, even if the clock jumped past several.
            while not stream.ended and stream.next_frame <= now:
                stream.outbox.append((stream.next_frame + delay, self._sample(stream)))
                stream.ended = stream.outbox[-1][1].status != TrackSample.STATUS_OK
                stream.next_frame += period
            while stream.outbox and stream.outbox[0][0] <= now:
                self._publish(publisher, stream.outbox.popleft()[1])
                self.track_traffic["samples_sent"] += 1
            if stream.ended and not stream.outbox:
                del self.relayed[key]

    def _sample(self, stream: Relayed) -> TrackSample:
        status, vector = self._senses.track_sample(
            stream.source, self.fls_id, stream.target, stream.next_frame / 1e9
        )
        sample = TrackSample(
            source_id=stream.source,
            relay_id=self.fls_id,
            target_id=stream.target,
            status=status,
            position=vector3(vector if status == RELAY_OK else None),
        )
        sample.header.stamp = to_stamp(stream.next_frame / 1e9)
        sample.header.frame_id = node_name(stream.source)
        return sample

    def on_track_sample(self, sample: TrackSample) -> None:
        """Take a relayed sample of a tracked target; publish the estimate of the present."""
        self.track_traffic["samples_heard"] += 1
        target = int(sample.target_id)
        track = self.tracks.get(target)
        if track is None or track.relay != sample.relay_id:
            return  # a stream this FLS stopped, or handed over
        sensed = to_seconds(sample.header.stamp)
        # The delay is known: the present is the sensing time plus the delay.
        present = arrival(sensed, self.track_config)
        if sample.status == TrackSample.STATUS_OK:
            try:
                track.add(sensed, array3(sample.position))
            except TrackingError:
                return  # out of order; the relay sends in order, so a duplicate
        else:
            successor = self._senses.next_relay(self.fls_id, target, track.relay, present)
            if successor is not None:
                track.handover(successor)
                self._request(TrackRequest.COMMAND_START, successor, target, nanoseconds(present))
                return
            track.end(RELAY_MESSAGES.get(sample.status, "the relay ended the stream"))
        self._publish_track(target, present)

    def _check_tracks(self) -> None:
        now = self._now() / 1e9
        for target, track in list(self.tracks.items()):
            if track.check(now):
                self._publish_track(target, now)

    def _publish_track(self, target: int, present: float) -> None:
        track = self.tracks[target]
        estimate = track.estimate(present)
        message = track_estimate_message(self.fls_id, target, track.tracker.model, estimate)
        self._publish(self._track_publisher(TrackEstimate, TRACK_ESTIMATES_TOPIC), message)
        self.track_traffic["estimates_sent"] += 1
        if estimate.status in (ENDED, TIMED_OUT):
            del self.tracks[target]

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
