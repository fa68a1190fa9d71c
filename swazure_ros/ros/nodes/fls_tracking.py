"""An FLS's part in tracking over ROS: its ``~/track`` service, the streams it relays, the
targets it tracks, and their frames on the node's clock (spec, section 9).

The algorithms are the protocol's machines: :class:`~..protocol.tracking.RelayStreams`
for the streams the FLS relays, :class:`~..protocol.tracking.TrackSource` for the
targets it tracks. :class:`FlsTracking` feeds them the node's requests, samples and
time, and publishes what they return.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.clock import Clock, JumpHandle, JumpThreshold
from rclpy.clock_type import ClockType
from rclpy.duration import Duration
from rclpy.publisher import Publisher
from rclpy.timer import Timer
from swazure_interfaces.msg import TrackEstimate, TrackProgress, TrackRequest, TrackSample
from swazure_interfaces.srv import TrackTarget

from ...core.arrays import FloatArray
from ...core.errors import SwazureError
from ...core.estimators import TrackingError
from ...core.relay import RelaySenses
from ...core.tracking import TrackConfig
from ...protocol.tracking import (
    STOP_RELAY,
    RelayRequest,
    RelayStreams,
    Sample,
    TrackProgressReport,
    TrackReport,
    TrackSource,
)
from ..convert.tracking import (
    relay_request_message,
    sample_message,
    track_estimate_message,
    track_progress_message,
)
from ..plumbing.names import (
    ROUND_QOS,
    TRACK_ESTIMATES_TOPIC,
    TRACK_MODEL_NAMES,
    TRACK_PROGRESS_TOPIC,
    TRACK_REQUESTS_TOPIC,
    TRACK_SAMPLES_TOPIC,
    TRACK_SERVICE,
)
from ..plumbing.node import SwarmNode
from ..plumbing.parameters import ParameterError
from ..security.guard import check
from . import fls_parameters
from .fls_parameters import TRACK_SETTINGS_SPECS

#: Wall s between looks at whether the track publishers have matched their readers.
MATCH_POLL = 0.1

#: The topics a track run publishes on, and their message types.
TRACK_TOPICS: dict[str, type] = {
    TRACK_REQUESTS_TOPIC: TrackRequest,
    TRACK_SAMPLES_TOPIC: TrackSample,
    TRACK_ESTIMATES_TOPIC: TrackEstimate,
    TRACK_PROGRESS_TOPIC: TrackProgress,
}


def _no_relay_senses() -> RelaySenses:
    raise TrackingError(
        "this FLS cannot choose relays: tracking needs the simulated world (swazure spawn)"
    )


#: The parameters an FLS node's tracking declares.
PARAMETERS = fls_parameters.TRACKING


class FlsTracking:
    """One FLS's tracking: parameters ``track.*``, the ``~/track`` service, relays and sources.

    ``node`` is FLS ``fls_id``'s; ``relay_senses`` chooses relays and takes
    relayed samples, where the FLS's senses can (the simulator). ``publish``
    sends a message as the node sends all of its own (signed and counted);
    ``elsewhere(fls_id, service, does)`` tells a caller where another FLS answers.
    ``declared`` are the values of :data:`PARAMETERS`, in order, which the node
    declares with its own (one ParameterEvent for all).
    """

    def __init__(
        self,
        node: SwarmNode,
        fls_id: int,
        relay_senses: Callable[[], RelaySenses] | None,
        publish: Callable[[Publisher, object], None],
        elsewhere: Callable[[int, str, str], str],
        declared: Sequence[Any],
    ) -> None:
        self.node = node
        self.fls_id = fls_id
        self._send = publish
        self._elsewhere = elsewhere
        self._relay_senses = relay_senses or _no_relay_senses
        # Off unless asked: a swarm's services are what its bring-up time grows
        # with, as the square of their number in a process (docs/swarm.md).
        self.service, self.report_progress, self.peers, *settings = declared
        self.config = self._config_of(settings)
        self.relay = RelayStreams(fls_id, self._sense_for_relay, self.config)
        self.tracker = TrackSource(
            fls_id,
            self.config,
            lambda target, seconds: self._relay_senses().choose_relay(fls_id, target, seconds),
            lambda target, relay, seconds: self._relay_senses().next_relay(
                fls_id, target, relay, seconds
            ),
        )
        if self.service:
            node.create_service(TrackTarget, f"~/{TRACK_SERVICE}", self._on_track)
        # Created at the first track: most FLSs never relay nor track, and
        # every endpoint costs discovery time. Under a driver of the clock in another
        # process, at once: a message sent before its readers have matched is lost.
        self._publishers: dict[str, Publisher] = {}
        self._matching: Timer | None = None
        if self.report_progress:
            for topic, kind in TRACK_TOPICS.items():
                self._publishers[topic] = node.create_publisher(kind, topic, ROUND_QOS)
            # The driver starts once every FLS has reported, and each reports first when its
            # requests and samples reach every peer's radio: the driver seeing a reader on
            # its graph does not make it matched to another process's writer, and a message
            # sent before its reader matched is lost for good (a loaded machine's track
            # waited for ever on a relay request sent too soon, 2026-11-29). On the wall
            # clock: the simulated one stands still until the driver starts.
            self._matching = node.create_timer(
                MATCH_POLL,
                self._report_when_matched,
                clock=Clock(clock_type=ClockType.STEADY_TIME),
            )
        # Relay frames and track timeouts run on the node's clock. On simulated
        # time they follow /clock itself: the EventsExecutor's timers do not
        # support a simulated clock (ros2/rclcpp#2457) and skip periods.
        self._ticks: JumpHandle | Timer | None = None
        # Sent and heard, so that whoever drives a simulated clock knows when all is delivered.
        self.traffic: Counter[str] = Counter()

    def _config_of(self, settings: list[Any]) -> TrackConfig:
        """The track settings declared (TRACK_SETTINGS_SPECS' values, in order) as a config."""
        values = {
            spec.name.removeprefix("track."): value
            for spec, value in zip(TRACK_SETTINGS_SPECS, settings, strict=True)
        }
        try:
            return TrackConfig(**values)
        except TrackingError as err:
            raise ParameterError(f"{self.node.get_fully_qualified_name()}: {err}") from err

    def _now(self) -> int:
        return self.node.get_clock().now().nanoseconds

    def _sense_for_relay(self, source: int, target: int, seconds: float) -> tuple[int, FloatArray]:
        return self._relay_senses().track_sample(source, self.fls_id, target, seconds)

    def _on_track(
        self, request: TrackTarget.Request, response: TrackTarget.Response
    ) -> TrackTarget.Response:
        response.success = False
        if request.source_id != self.fls_id:
            response.message = self._elsewhere(request.source_id, TRACK_SERVICE, "tracks")
            return response
        model = TRACK_MODEL_NAMES.get(request.model)
        if model is None:
            response.message = f"unknown model {request.model}: use TrackTarget.MODEL_*"
            return response
        target = int(request.target_id)
        try:
            requests = self.tracker.begin(target, model, self._now())
        except SwazureError as err:
            response.message = str(err)
            return response
        for one in requests:
            self._publish(one)
        self._start_ticks()
        self._report_progress()
        relay = self.tracker.relay(target)
        response.success, response.relay_id = True, relay
        response.message = f"tracking FLS {target} through FLS {relay}"
        return response

    def on_request(self, request: RelayRequest) -> None:
        """Start or stop relaying a target to a source (the radio hands requests to the relay).

        MessageError when its first frame is more than a track's timeout away
        from now: its source would have timed out (a zero stamp, as
        ``ros2 topic pub`` sends, would otherwise replay every frame since 1970).
        """
        now, timeout = self._now(), round(self.config.timeout * 1e9)
        check(
            request.command == STOP_RELAY or abs(request.start - now) <= timeout,
            f"first frame {(request.start - now) / 1e9:+.3g} s from now, beyond the timeout",
        )
        self.traffic["requests_heard"] += 1
        self.relay.on_request(request)
        self._start_ticks()
        self._relay_frames()
        self._report_progress()

    def stop_relaying(self, source: int, target: int) -> None:
        """Stop relaying ``target`` to ``source`` (its process relays too many streams)."""
        self.relay.on_request(RelayRequest(STOP_RELAY, source, self.fls_id, target, 0))

    def on_sample(self, sample: Sample) -> None:
        """Take a relayed sample of a tracked target; publish the estimate of the present."""
        self.traffic["samples_heard"] += 1
        for out in self.tracker.on_sample(sample):
            self._publish(out)
        self._report_progress()

    @property
    def ticking(self) -> bool:
        """Whether this FLS's frames run (it relays or tracks, or did on a simulated clock)."""
        return self._ticks is not None

    def _start_ticks(self) -> None:
        if self._ticks is not None:
            return
        node = self.node
        if node.get_parameter("use_sim_time").value:
            self._ticks = node.get_clock().create_jump_callback(
                JumpThreshold(min_forward=Duration(nanoseconds=1), min_backward=None),
                post_callback=lambda jump: self._on_tick(),
            )
        else:
            self._ticks = node.create_timer(self.config.frame_period, self._on_tick)

    def _on_tick(self) -> None:
        self._relay_frames()
        for report in self.tracker.tick(self._now()):
            self._publish(report)
        self._report_progress()
        # Nothing left to relay or track: the frames stop until the next request, so that
        # every FLS a flood of requests once reached does not tick for ever.
        idle = not len(self.relay) and not self.tracker.tracks and not self.report_progress
        if idle and isinstance(self._ticks, Timer):
            self.node.destroy_timer(self._ticks)
            self._ticks = None

    def readers(self, topic: str) -> int:
        """Readers matched to this FLS's track publisher on ``topic`` (0 before it has one)."""
        publisher = self._publishers.get(topic)
        return 0 if publisher is None else publisher.get_subscription_count()

    def matched(self) -> bool:
        """Whether its requests and samples reach ``track.peers`` radios, the rest a driver."""
        wanted = {TRACK_REQUESTS_TOPIC: self.peers, TRACK_SAMPLES_TOPIC: self.peers}
        return all(self.readers(topic) >= wanted.get(topic, 1) for topic in TRACK_TOPICS)

    def _report_when_matched(self) -> None:
        if self._matching is not None and self.matched():
            self.node.destroy_timer(self._matching)
            self._matching = None
            # Reported once, it follows the driver's clock: its report at each tick tells
            # the driver it has caught up, or the driver would wait for it at the next.
            self._start_ticks()
            self._report_progress()

    def _report_progress(self) -> None:
        if self.report_progress:
            now = self._now()
            progress = TrackProgressReport(
                self.fls_id, now, Counter(self.traffic), self.relay.due(now)
            )
            self._publish(track_progress_message(progress))

    def _relay_frames(self) -> None:
        for sample in self.relay.tick(self._now()):
            self._publish(sample)

    def _publish(self, out: RelayRequest | Sample | TrackReport | TrackProgress) -> None:
        if isinstance(out, TrackProgress):
            message: object = out
            topic, counter = TRACK_PROGRESS_TOPIC, "progress_sent"
        elif isinstance(out, RelayRequest):
            message = relay_request_message(out)
            topic, counter = TRACK_REQUESTS_TOPIC, "requests_sent"
        elif isinstance(out, Sample):
            message = sample_message(out)
            topic, counter = TRACK_SAMPLES_TOPIC, "samples_sent"
        else:
            message = track_estimate_message(out)
            topic, counter = TRACK_ESTIMATES_TOPIC, "estimates_sent"
        if topic not in self._publishers:
            kind = TRACK_TOPICS[topic]
            self._publishers[topic] = self.node.create_publisher(kind, topic, ROUND_QOS)
        self._send(self._publishers[topic], message)
        self.traffic[counter] += 1
