"""One process's radio on ROS: what its FLSs hear, each message once, handed to those it reaches.

A packed process (:mod:`.host`) hosts hundreds of FLSs behind one radio; an FLS
in its own process (:func:`.fls_program.build_fls`) hosts itself behind one.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.timer import Timer
from swazure_interfaces.msg import (
    DiscoveryControl,
    Measurements,
    PathOffer,
    PathWalk,
    RoundAck,
    TrackRequest,
    TrackSample,
)

from ..core.fit import PATH
from ..protocol.discovery.messages import END, START
from ..protocol.moves import Walk
from ..protocol.plausible import (
    implausible_readings,
    offer_readings_check,
    round_labels_check,
)
from ..protocol.radio import Ack, RadioHub, RadioLoss
from ..protocol.readings import ReadingsBook
from ..protocol.senses import Senses
from .convert.discovery import (
    ack_message,
    control_from_message,
    offer_from_message,
    walk_from_message,
    walk_message,
)
from .convert.sensing import readings_from_message
from .convert.tracking import relay_request_from_message, sample_from_message
from .guard import Guard
from .names import (
    ACK_TOPIC,
    CONTROL_TOPIC,
    MEASUREMENTS_TOPIC,
    RADIO_TOPIC,
    READINGS_QOS,
    ROUND_QOS,
    TRACK_REQUESTS_TOPIC,
    TRACK_SAMPLES_TOPIC,
    WALKS_TOPIC,
)

if TYPE_CHECKING:
    from .fls_node import FlsNode

#: Path walks a process keeps while they wait for a newer world revision (a heuristic
#: walks a few paths per group of moves).
EARLY_WALKS = 4096
#: Seconds a source of a fitting run waits, after the END, for the readings of its
#: window before it fits what it heard. The readings are asked for at the run's START
#: and are in long before its END; this must stay below the coordinator's round timeout.
READINGS_WAIT = 1.0
IntArray = NDArray[np.int64]


class Radio:
    """The radio medium of one process (:class:`~swazure_ros.protocol.radio.RadioHub`) on ROS.

    It hears every broadcast on ``radio`` once and hands it to the local FLS
    nodes within radio range of the sender, as a real radio would; it hands
    the coordinator's controls to every local FLS; and once it has delivered
    every offer of a round, it acknowledges the round on ``round_acks``. Path
    walks on ``path_walks`` go to the FLS they are addressed to, once this
    process has the world revision they must be measured in; track requests
    go to their relay and track samples to their source. From the first
    fitting run on, it hears every FLS's ``measurements`` into ``readings``,
    the book its FLSs' fits take their windows from.
    """

    def __init__(
        self,
        node: Node,
        senses: Senses,
        fls_nodes: dict[int, FlsNode],
        loss: RadioLoss | None = None,
        guard: Guard | None = None,
        listen: bool = True,
        readings: ReadingsBook | None = None,
    ) -> None:
        self._node = node
        self.readings = ReadingsBook() if readings is None else readings
        self._hears_readings = False
        self._waiting: set[int] = set()  # local sources whose fit waits for readings
        self._senses = senses
        self._fls = fls_nodes
        self._hub = RadioHub(
            fls_nodes.keys(),
            loss,
            lambda fls_id: senses.view(fls_id).other.astype(np.int64),
            round_labels_check(senses.positions, senses.sensor, senses.radius),
            offer_readings_check(senses.positions, senses.sensor, senses.radius),
        )
        self.controls_heard = 0  # a control is a sure sign that a coordinator is there
        self.last_control_at = float("-inf")  # monotonic s
        self.guard = guard or Guard(node)
        self._acks = node.create_publisher(RoundAck, ACK_TOPIC, ROUND_QOS)
        self.listening = False
        if listen:
            self.listen()
        self._subscribe(PathOffer, RADIO_TOPIC, self._on_offer)
        # One walk publisher per process, not per FLS: a thousand more endpoints
        # would slow the swarm's discovery for a message few FLSs ever send.
        self._walks = node.create_publisher(PathWalk, WALKS_TOPIC, ROUND_QOS)
        # Walks that must wait for a newer world revision, the oldest dropped first.
        self._early_walks: deque[Walk] = deque(maxlen=EARLY_WALKS)
        self._subscribe(PathWalk, WALKS_TOPIC, self._on_walk)
        senses.on_revision.append(self._take_early_walks)
        self._subscribe(TrackRequest, TRACK_REQUESTS_TOPIC, self._on_track_request)
        self._subscribe(TrackSample, TRACK_SAMPLES_TOPIC, self._on_track_sample)

    def listen(self) -> None:
        """Hear the coordinator's controls: from now on the swarm's rounds count on this radio."""
        if not self.listening:
            self._subscribe(DiscoveryControl, CONTROL_TOPIC, self._on_control)
            self.listening = True

    def ack_readers(self) -> int:
        """Readers matched to this radio's acknowledgements (the coordinator's)."""
        return self._acks.get_subscription_count()

    def _subscribe(
        self, kind: type, topic: str, callback: Callable[[Any], None], qos: QoSProfile = ROUND_QOS
    ) -> None:
        self.guard.subscribe(kind, topic, callback, qos)

    @property
    def _swarm(self) -> IntArray:
        return self._senses.ids

    def coordinator_lost(self) -> int:
        """The coordinator left mid-run: every local FLS drops its runs, sources report ABORTED.

        Returns the number of ABORTED estimates sent.
        """
        self._hub.abandon()
        return sum(node.abandon_runs() for node in self._fls.values())

    def _on_track_request(self, message: TrackRequest) -> None:
        request = relay_request_from_message(message, self._swarm)
        node = self._fls.get(request.relay)
        if node is not None:
            node.tracking.on_request(request)

    def _on_track_sample(self, message: TrackSample) -> None:
        sample = sample_from_message(message, self._swarm)
        node = self._fls.get(sample.source)
        if node is not None:
            node.tracking.on_sample(sample)

    def _on_control(self, message: DiscoveryControl) -> None:
        control = control_from_message(message, self._swarm)
        self.controls_heard += 1
        self.last_control_at = time.monotonic()
        if control.command == START and control.estimator != PATH:
            self._hear_readings()
        recipients, ack, heard = self._hub.on_control(control)
        for sender, why in self._hub.rejected:
            self.guard.drop(RADIO_TOPIC, f"implausible: {why}", f"FLS {sender}'s offer: {why}")
        self._hub.rejected.clear()
        for fls_id in recipients:
            self._fls[fls_id].on_control(control, heard)
            if control.command == END and self._fls[fls_id].discovery.waiting:
                self._waiting.add(fls_id)
        if control.command == END and self._waiting:
            timer = self._node.create_timer(READINGS_WAIT, lambda: self._report_waiting(timer))
        self._acknowledge(ack)

    def _hear_readings(self) -> None:
        # Only once a run fits: thousands of measurements are work nobody else needs.
        if not self._hears_readings:
            self._hears_readings = True
            self._subscribe(Measurements, MEASUREMENTS_TOPIC, self._on_measurements, READINGS_QOS)

    def _on_measurements(self, message: Measurements) -> None:
        readings = readings_from_message(message, self._swarm)
        senses = self._senses
        why = implausible_readings(readings, senses.positions, senses.sensor, senses.radius)
        if why is not None:
            self.guard.drop(MEASUREMENTS_TOPIC, f"implausible: {why}")
            return
        self.readings.put(readings)
        if self._waiting:
            self._report_waiting()

    def _report_waiting(self, deadline: Timer | None = None) -> None:
        """Local sources report the fits whose windows are heard; all of them at a ``deadline``."""
        if deadline is not None:
            self._node.destroy_timer(deadline)
        for fls_id in list(self._waiting):
            node = self._fls.get(fls_id)
            if node is None or node.report_waiting(at_deadline=deadline is not None):
                self._waiting.discard(fls_id)

    def _on_offer(self, message: PathOffer) -> None:
        # Its labels' meaning is checked once a round, with every offer heard (_implausible).
        offer = offer_from_message(message, self._swarm)
        self._acknowledge(
            self._hub.on_offer(int(message.run_id), int(message.round), message.sender_id, offer)
        )

    def _acknowledge(self, ack: Ack | None) -> None:
        if ack is None:
            return
        if ack.latency <= 0:
            self._send_ack(ack)
            return

        # A slow radio's last delivery of the round arrives this late: so does the ack.
        def send_once() -> None:
            self._node.destroy_timer(timer)
            self._send_ack(ack)

        timer = self._node.create_timer(ack.latency, send_once)

    def _send_ack(self, ack: Ack) -> None:
        stamp = self._node.get_clock().now().to_msg()
        self._acks.publish(
            self.guard.key.serialize(ack_message(ack, self._node.get_name(), stamp))
        )

    def _on_walk(self, message: PathWalk) -> None:
        self._take_walk(walk_from_message(message, self._swarm))

    def _take_walk(self, walk: Walk) -> None:
        node = self._fls.get(walk.at)
        if node is None:
            return  # another process's FLS, or a stopped one
        if walk.revision > self._senses.revision:
            self._early_walks.append(walk)
            return
        onward = node.on_walk(walk)
        if onward is not None:
            stamp = self._node.get_clock().now().to_msg()
            self._walks.publish(self.guard.key.serialize(walk_message(onward, stamp)))

    def _take_early_walks(self) -> None:
        early = list(self._early_walks)
        self._early_walks.clear()
        for walk in early:
            self.guard.call(WALKS_TOPIC, self._take_walk, walk)
