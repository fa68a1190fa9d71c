"""One process's radio on ROS: what its FLSs hear, each message once, handed to those it reaches.

A packed process (:mod:`.host`) hosts hundreds of FLSs behind one radio; an FLS
in its own process (:func:`.fls_program.build_fls`) hosts itself behind one.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable, Sequence
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numpy as np
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription
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

from ...core.arrays import IntArray
from ...core.fit import PATH
from ...core.observe import Measurement
from ...protocol.cells import BANDS, DECAYING_BAND, Cell, Tuner, Tuning, band_of, radio_cells
from ...protocol.discovery.messages import END, ROUND, START, Broadcast, FitBlock
from ...protocol.discovery.participant import step_together
from ...protocol.moves import WALKING, Walk, hops_here
from ...protocol.plausible import (
    implausible_readings,
    offer_readings_check,
    round_labels_check,
)
from ...protocol.radio import Ack, RadioHub
from ...protocol.radio_loss import RadioLoss
from ...protocol.readings import ReadingsBook
from ...protocol.senses import Senses
from ...protocol.tracking import STOP_RELAY, Stream, StreamBound
from ..convert.discovery import (
    ack_message,
    control_from_message,
    sent_message,
    walk_fields,
    walk_from_message,
)
from ..convert.measurements import MeasurementsBytes, read_measurements, readings_of
from ..convert.offers import offer_fields, offer_from_message
from ..convert.tracking import relay_request_from_message, sample_from_message
from ..plumbing.echoes import Echoes
from ..plumbing.names import (
    ACK_TOPIC,
    CONTROL_TOPIC,
    MEASUREMENTS_TOPIC,
    RADIO_TOPIC,
    READINGS_QOS,
    ROUND_QOS,
    TRACK_REQUESTS_TOPIC,
    TRACK_SAMPLES_TOPIC,
    WALKS_TOPIC,
    radio_topic,
    walks_topic,
)
from ..security.guard import Guard, RateLimit, check
from ..security.records import record_parser, record_writer
from .heartbeats import Heartbeats

if TYPE_CHECKING:
    from .fls_node import FlsNode

#: Path walks a process keeps while they wait for a newer world revision (a heuristic
#: walks a few paths per group of moves).
EARLY_WALKS = 4096
#: Track requests a process takes from one sender (without a key, from all senders
#: together): each starts a relay's stream of frames. A track starts with one request a
#: relay; a few dozen tracks at once are a burst. The streams are bounded too
#: (protocol.tracking.RELAYED_STREAMS).
TRACK_REQUEST_RATE = RateLimit(per_second=20.0, burst=200.0)
#: Offers per local FLS whose bytes a process keeps to know their echoes: a few rounds'.
ECHOES_PER_FLS = 8
#: Seconds a source of a fitting run waits, after the END, for the readings of its
#: window before it fits what it heard. The readings are asked for at the run's START
#: and are in long before its END; this must stay below the coordinator's round timeout.
#: Only a window still missing a reading waits: 1 s was too short for 25 FLS processes
#: on a loaded 2-core machine (CI: a fit of what was heard, 5 estimates not the engine's).
READINGS_WAIT = 3.0


_DISCOVERY = attrgetter("discovery")
#: The messages of rounds and walks, read and written as bytes (:mod:`..security.records`): a
#: round brings an offer from every FLS heard and sends one from every FLS here.
_RECORDS = {kind: record_parser(kind) for kind in (PathOffer, PathWalk)}
_OFFER_BYTES = record_writer(PathOffer)
_WALK_BYTES = record_writer(PathWalk)


class Radio:
    """The radio medium of one process (:class:`~swazure_ros.protocol.radio.RadioHub`) on ROS.

    It hears every broadcast in the radio cells around its FLSs
    (``radio/c<i>_<j>_<k>``, :mod:`~swazure_ros.protocol.cells`) once, and hands
    it to the local FLS nodes within radio range of the sender, as a real radio
    would; it sends its FLSs' offers on their own cells' topics; it hands
    the coordinator's controls to every local FLS; and once it has delivered
    every offer of a round, it acknowledges the round on ``round_acks``, where it
    has also told the coordinator which of its FLSs spoke in that round. Path
    walks go to the FLS they are addressed to, once this process has the world
    revision they must be measured in: the coordinator's first hops on
    ``path_walks``, an FLS's next hop at once when it is local, else on the
    sender's ``path_walks/c<i>_<j>_<k>`` (a cell of the ``decaying`` band,
    which holds every FLS the sender can measure); track requests
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
        local: Sequence[int] | None = None,
    ) -> None:
        self._node = node
        #: The FLSs this process hosts (those of ``fls_nodes`` when None), for its cells.
        self._local = np.array(sorted(fls_nodes if local is None else local), dtype=np.int64)
        self._cells = radio_cells(senses.sensor, senses.radius)
        self._listening: dict[Cell, Subscription] = {}  # the radio cells heard, per band
        self._sending: dict[Cell, Publisher] = {}  # the radio cells of this process's FLSs
        # The path walks' cells (of the decaying band): heard, and sent on.
        self._walks_heard: dict[Cell, Subscription] = {}
        self._walks_sent: dict[Cell, Publisher] = {}
        # Per band: the FLSs in the cells heard, and of each cell sent on, its readers.
        self._audible = {band: np.zeros(0, dtype=np.int64) for band in BANDS}
        self._tuning: Tuning | None = None  # where its FLSs are, cell by cell (tune())
        self._tuner = Tuner(self._cells, self._local)
        self._local_set = frozenset(self._local.tolist())
        # The offers sent lately, to know them when a shared cell brings them back.
        self._echoes = Echoes(ECHOES_PER_FLS * max(len(self._local), 1))
        #: Offers heard: from this process's own FLSs, and from other processes' over DDS.
        self.offers_here = 0
        self.offers_heard = 0
        #: Path walks handed from one FLS of this process to another, and sent over DDS.
        self.walks_here = 0
        self.walks_sent = 0
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
            audible=lambda phase: self._audible[band_of(phase)],
        )
        self.controls_heard = 0  # a control is a sure sign that a coordinator is there
        self.last_control_at = float("-inf")  # monotonic s
        self.guard = guard or Guard(node)
        self._acks = node.create_publisher(RoundAck, ACK_TOPIC, ROUND_QOS)
        self.listening = False
        self._controls: Subscription | None = None
        self._newest = (0, 0)  # (run, round) of the newest control heard
        #: What this radio says of itself: alive, hearing the controls, or behind.
        self.heartbeats = Heartbeats(node, self.guard.key, self.hears_controls, self.newest)
        # Walks that must wait for a newer world revision, the oldest dropped first.
        self._early_walks: deque[Walk] = deque(maxlen=EARLY_WALKS)
        if listen:
            self.listen()
        self.tune()
        senses.on_revision.append(self.tune)
        # The coordinator's walks: one writer, every process a reader.
        self._subscribe(PathWalk, WALKS_TOPIC, self._on_walk)
        senses.on_revision.append(self._take_early_walks)
        # Each request starts a relay's stream of frames: a flood of them must not, and
        # what one leaves behind is bounded.
        self.relayed = StreamBound()
        self.guard.subscribe(
            TrackRequest,
            TRACK_REQUESTS_TOPIC,
            self._on_track_request,
            ROUND_QOS,
            rate=TRACK_REQUEST_RATE,
        )
        self._subscribe(TrackSample, TRACK_SAMPLES_TOPIC, self._on_track_sample)

    def tune(self) -> None:
        """Hear the radio cells around this process's FLSs where they are now; send on theirs.

        Called at each world revision: an FLS a heuristic moved into another
        cell is heard there from then on. Publishers are made here, ahead of
        the runs that use them, so that they have matched their readers by then.
        """
        senses = self._senses
        tuning = self._tuner.tune(senses.ids, senses.positions(senses.ids))
        if tuning is None:
            return  # no FLS changed cell: every cell heard or sent on, and who is heard, stays
        self._tuning, self._audible = tuning, tuning.audible
        heard, mine = set(tuning.heard), set(tuning.mine)
        self._retune(
            self._listening, heard, lambda cell: self._hear(PathOffer, cell, self._on_offer)
        )
        self._retune(self._sending, mine, lambda cell: self._send_on(PathOffer, cell))
        # A walk crosses DDS only to another process's FLS, in the cell of its sender.
        walking = {cell for cell in heard if cell[0] == DECAYING_BAND}
        self._retune(
            self._walks_heard, walking, lambda cell: self._hear(PathWalk, cell, self._on_walk)
        )
        sending = {cell for cell in mine if cell[0] == DECAYING_BAND}
        self._retune(self._walks_sent, sending, lambda cell: self._send_on(PathWalk, cell))

    def _retune(
        self, current: dict[Cell, Any], wanted: set[Cell], make: Callable[[Cell], Any]
    ) -> None:
        """Destroy the endpoints of ``current`` not ``wanted``; ``make`` those missing."""
        for cell in sorted(set(current) - wanted):
            endpoint = current.pop(cell)
            if isinstance(endpoint, Publisher):
                self._node.destroy_publisher(endpoint)
            else:
                self._node.destroy_subscription(endpoint)
        for cell in sorted(wanted - set(current)):
            current[cell] = make(cell)

    def _hear(self, kind: type, cell: Cell, callback: Callable[[Any], None]) -> Subscription:
        read, topic = self.guard.record_reader(_RECORDS[kind]), self._topic(kind, cell)
        return self.guard.subscribe(
            kind, topic, callback, ROUND_QOS, echoes=self._echoes, read=read
        )

    def _send_on(self, kind: type, cell: Cell) -> Publisher:
        return self._node.create_publisher(kind, self._topic(kind, cell), ROUND_QOS)

    @staticmethod
    def _topic(kind: type, cell: Cell) -> str:
        indices = [int(index) for index in cell[1:]]
        return walks_topic(indices) if kind is PathWalk else radio_topic(str(cell[0]), indices)

    def cell_readers(self) -> tuple[int, int]:
        """(readers matched to this process's cells' offers and walks, those wanted), summed.

        One process per FLS: every other FLS within one cell of this one's (of
        each band) hears its offers, and those of the decaying band its walks,
        so the first number reaches the second once all of them listen. This
        process's own reader of a cell it also sends on is matched to its
        writer too (DDS matches a participant's endpoints with each other) and
        is wanted as well: counted as one of the others', it let an FLS take
        part while one neighbour's reader was still unmatched, and two FLSs
        missed each other's first offers (a round 0 waited out its whole
        timeout in 5 of 16 loaded bring-ups of grid25, 2026-11-28).
        """
        readers = wanted = 0
        sending = [(cell, publisher, self._listening) for cell, publisher in self._sending.items()]
        sending += [
            (cell, publisher, self._walks_heard) for cell, publisher in self._walks_sent.items()
        ]
        for cell, publisher, heard in sending:
            audible = self._audible[str(cell[0])]
            want = int(np.count_nonzero(~np.isin(audible, self._local))) + int(cell in heard)
            readers += min(publisher.get_subscription_count(), want)
            wanted += want
        return readers, wanted

    def _cell(self, band: str, fls_id: int) -> Cell:
        """The cell of ``band`` that holds local FLS ``fls_id`` now."""
        return self._cells_of([(band, fls_id)])[0]

    def _cells_of(self, wanted: Sequence[tuple[str, int]]) -> list[Cell]:
        """:meth:`_cell` of each (band, local FLS id) of ``wanted``, looked up together."""
        cells: list[Cell | None] = [None] * len(wanted)
        if self._tuning is not None:
            for band in {band for band, _ in wanted}:
                at = [k for k, (of, _) in enumerate(wanted) if of == band]
                ids = np.array([wanted[k][1] for k in at], dtype=np.int64)
                for k, cell in zip(at, self._tuning.cells_of(band, ids), strict=True):
                    cells[k] = cell
        return [
            self._cell_now(band, fls_id) if cell is None else cell
            for cell, (band, fls_id) in zip(cells, wanted, strict=True)
        ]

    def _cell_now(self, band: str, fls_id: int) -> Cell:
        """The cell of ``band`` where FLS ``fls_id`` is now, from its place: an FLS not
        hosted here at the start, which the tuning does not place."""
        where = self._cells[band].of(self._senses.positions(np.array([fls_id])))[0]
        return (band, *where.tolist())

    def broadcast(self, offers: Sequence[Broadcast]) -> list[int]:
        """Local FLSs' ``offers`` of one round: heard here at once, sent on their cells' topics.

        An offer crosses DDS only when someone else reads its cell (another
        process, a recorder, ``ros2 topic echo``), asked once a cell: the
        bytes sent of each, 0 when no one reads it.
        """
        sizes: list[int] = []
        read: dict[Cell, bool] = {}  # whether anyone else reads a cell
        stamp = None
        hub = self._hub
        cells = self._cells_of([(band_of(out.phase), out.sender) for out in offers])
        for out, cell in zip(offers, cells, strict=True):
            publisher = self._offers_publisher(cell)
            if cell not in read:
                read[cell] = publisher.get_subscription_count() > 0
            size = 0
            if read[cell]:
                stamp = stamp or self._node.get_clock().now().to_msg()
                size = self._send_offer(publisher, out, stamp)
            sizes.append(size)
        hub.sent_all(offers, sizes)
        self.offers_here += len(offers)
        if offers:
            self._acknowledge(hub.on_offers(offers[0].run_id, offers[0].round, offers))
            self._count_rejected()
        return sizes

    def broadcast_block(self, block: FitBlock) -> list[int]:
        """Local FLSs' offers of ``block``, as :meth:`broadcast` sends each: heard here at once,
        and on the wire, a PathOffer a row, only in the cells that someone else reads.

        Returns the bytes sent of each row.
        """
        sizes = [0] * len(block)
        stamp = None
        for cell, rows in self._rows_by_cell(band_of(block.phase), block.senders):
            publisher = self._offers_publisher(cell)
            if publisher.get_subscription_count() > 0:
                stamp = stamp or self._node.get_clock().now().to_msg()
                for row in rows.tolist():
                    sizes[row] = self._send_offer(publisher, block.broadcast(row), stamp)
        self._hub.sent_block(block, sum(sizes))
        self.offers_here += len(block)
        self._acknowledge(self._hub.on_block(block))
        self._count_rejected()
        return sizes

    def _offers_publisher(self, cell: Cell) -> Publisher:
        """The offers' publisher of ``cell`` (made on demand for an FLS that was not hosted
        here at the start)."""
        publisher = self._sending.get(cell)
        if publisher is None:
            publisher = self._sending[cell] = self._send_on(PathOffer, cell)
        return publisher

    def _send_offer(self, publisher: Publisher, out: Broadcast, stamp: Any) -> int:
        """Sign and publish ``out`` as a PathOffer stamped ``stamp``: the bytes sent."""
        data = _OFFER_BYTES(offer_fields(out, stamp), self.guard.key.auth)
        self._echoes.add(data)
        publisher.publish(data)
        return len(data)

    def _rows_by_cell(self, band: str, ids: IntArray) -> list[tuple[Cell, IntArray]]:
        """The rows of local FLSs ``ids`` by the cell of ``band`` that holds each now."""
        groups: list[tuple[Cell, IntArray]] = []
        unplaced = np.arange(len(ids))
        if self._tuning is not None:
            groups, unplaced = self._tuning.rows_by_cell(band, ids)
        for row in unplaced.tolist():
            groups.append((self._cell_now(band, int(ids[row])), np.array([row])))
        return groups

    def listen(self) -> None:
        """Hear the coordinator's controls: from now on the swarm's rounds count on this radio."""
        if not self.listening:
            self._controls = self._subscribe(DiscoveryControl, CONTROL_TOPIC, self._on_control)
            self.listening = True

    def hears_controls(self) -> bool:
        """Whether this radio listens and its reader of the controls has matched their writer.

        Only the radio sees its own reader matched; the coordinator sees its
        writer matched, which can be sooner, and a control sent to a reader
        that has not matched yet is lost to it (its heartbeats say this).
        """
        return self._controls is not None and self._controls.get_publisher_count() > 0

    def newest(self) -> tuple[int, int]:
        """(run, round) of the newest control this radio heard; (0, 0) before any."""
        return self._newest

    def ack_readers(self) -> int:
        """Readers matched to this radio's acknowledgements (the coordinator's)."""
        return self._acks.get_subscription_count()

    def _subscribe(
        self, kind: type, topic: str, callback: Callable[[Any], None], qos: QoSProfile = ROUND_QOS
    ) -> Subscription:
        parse = _RECORDS.get(kind)
        read = None if parse is None else self.guard.record_reader(parse)
        return self.guard.subscribe(kind, topic, callback, qos, read=read)

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
        if node is None:
            return
        node.tracking.on_request(request)
        stream = (request.relay, request.source, request.target)
        if request.command == STOP_RELAY:
            self.relayed.stopped(stream)
            return
        for relay, source, target in self.relayed.started(stream, self._relaying):
            self._fls[relay].tracking.stop_relaying(source, target)
            self.guard.drop(
                TRACK_REQUESTS_TOPIC,
                f"over {self.relayed.most} streams relayed at once: the oldest stopped",
            )

    def _relaying(self, stream: Stream) -> bool:
        """Whether local relay ``stream[0]`` still relays ``stream``."""
        node = self._fls.get(stream[0])
        return node is not None and node.tracking.relay.relays(stream[1], stream[2])

    def _on_track_sample(self, message: TrackSample) -> None:
        sample = sample_from_message(message, self._swarm)
        node = self._fls.get(sample.source)
        if node is not None:
            node.tracking.on_sample(sample)

    def _on_control(self, message: DiscoveryControl) -> None:
        control = control_from_message(message, self._swarm)
        self.controls_heard += 1
        self.last_control_at = time.monotonic()
        self._newest = (control.run_id, control.round)
        if control.command == START and control.estimator != PATH:
            self._hear_readings()
        recipients, ack, heard = self._hub.on_control(control)
        self._count_rejected()
        # This process's FLSs hear the round's offers, pick their labels and offer together;
        # those that did are done with a ROUND.
        # Lists of thousands a round: made by map, not by a Python loop.
        local = list(map(self._fls.__getitem__, recipients))
        stepped = step_together(list(map(_DISCOVERY, local)), control, heard)
        block, made = stepped.block, stepped.broadcasts
        rest = (
            local if block is None else list(map(self._fls.__getitem__, stepped.left(recipients)))
        )
        offers, senders = [], []
        for node in rest:
            out = made.get(node.fls_id) or node.on_control(control, heard)
            if out is not None:
                offers.append(out)
                senders.append(node)
            if control.command == END and node.discovery.waiting:
                self._waiting.add(node.fls_id)
        for node, size in zip(senders, self.broadcast(offers), strict=True):
            node.count_sent(size)
        if block is not None:
            fls = self._fls
            for fls_id, size in zip(block.senders.tolist(), self.broadcast_block(block)):
                fls[fls_id].count_sent(size)
        if control.command == ROUND:
            # Who of this process's FLSs spoke, at once: the coordinator hears no offer.
            sent = self._hub.take_sent(control.run_id, control.round)
            if sent.senders:
                stamp = self._node.get_clock().now().to_msg()
                message = sent_message(control, sent, self._node.get_name(), stamp)
                self._acks.publish(self.guard.key.serialize(message))
        if control.command == END and self._waiting:
            timer = self._node.create_timer(READINGS_WAIT, lambda: self._report_waiting(timer))
        self._acknowledge(ack)

    def _count_rejected(self) -> None:
        """Count the offers the hub found false since the last look (RadioHub.rejected)."""
        for sender, why in self._hub.rejected:
            self.guard.drop(RADIO_TOPIC, f"implausible: {why}", f"FLS {sender}'s offer: {why}")
        self._hub.rejected.clear()

    def _hear_readings(self) -> None:
        # Only once a run fits: thousands of measurements are work nobody else needs.
        if not self._hears_readings:
            self._hears_readings = True
            # Read as bytes: rclpy makes a message object of hundreds of poses in 0.1 s.
            read = self.guard.record_reader(read_measurements)
            self.guard.subscribe(
                Measurements, MEASUREMENTS_TOPIC, self._on_measurements, READINGS_QOS, read=read
            )

    def _on_measurements(self, message: MeasurementsBytes) -> None:
        readings = readings_of(message, self._swarm)
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
        # This process's own offers are heard when sent (broadcast), and their echoes
        # from a shared cell never get here (_echoes): this one is someone else's.
        check(message.sender_id not in self._local_set, "names an FLS of this process")
        self.offers_heard += 1
        # Its labels' meaning is checked in one batch a round, before the ack they complete
        # (RadioHub._settle): a false one counts for nobody.
        offer = offer_from_message(message, self._swarm)
        run, round_, phase = int(message.run_id), int(message.round), int(message.phase)
        self._acknowledge(self._hub.on_offer(run, round_, message.sender_id, offer, phase))
        self._count_rejected()

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
        ahead: dict[int, Measurement] | None = None  # its hops out here, read at once, by hop
        while walk.at in self._local_set:
            node = self._fls.get(walk.at)
            if node is None:
                return  # a stopped FLS
            if walk.revision > self._senses.revision:
                self._early_walks.append(walk)
                return
            if ahead is None:
                fls_ids, next_ids = hops_here(walk, self._local_set)
                readings = self._senses.hop_measurements(fls_ids, next_ids) if fls_ids else []
                ahead = dict(zip(range(walk.hop, walk.hop + len(readings)), readings))
            seen = ahead.pop(walk.hop, None) if walk.state == WALKING else None
            onward = node.on_walk(walk, seen)
            if onward is None:
                return
            if onward.at not in self._local_set:
                self._send_walk(onward, sender=walk.at)
                return
            self.walks_here += 1  # to another FLS of this process: no need to cross DDS
            walk = onward

    def _send_walk(self, walk: Walk, sender: int) -> None:
        """Send ``walk`` on the walks topic of local FLS ``sender``'s cell."""
        cell = self._cell(DECAYING_BAND, sender)
        publisher = self._walks_sent.get(cell)
        if publisher is None:
            publisher = self._walks_sent[cell] = self._send_on(PathWalk, cell)
        stamp = self._node.get_clock().now().to_msg()
        data = _WALK_BYTES(walk_fields(walk, stamp), self.guard.key.auth)
        self._echoes.add(data)
        publisher.publish(data)
        self.walks_sent += 1

    def _take_early_walks(self) -> None:
        early = list(self._early_walks)
        self._early_walks.clear()
        for walk in early:
            self.guard.call(WALKS_TOPIC, self._take_walk, walk)
