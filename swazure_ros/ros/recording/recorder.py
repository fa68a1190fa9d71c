"""Recording a swarm's topics as a rosbag2 bag, as the wire's own CDR bytes.

A raw subscription hands rclpy's callback the CDR bytes DDS carried, so a
recording holds what was sent: nothing is deserialised to record it.
:class:`Recorder` subscribes to every topic under the swarm's namespace as
it appears on the graph (as ``ros2 bag record`` does), with the QoS its
publishers offer, and writes a bag folder that ``ros2 bag info`` and
``play``, rosbags and Foxglove read (:mod:`.metadata`: its layout).
"""

from __future__ import annotations

import contextlib
import time
from contextlib import ExitStack
from functools import partial
from pathlib import Path

import yaml
from mcap.writer import Writer
from rclpy.context import Context
from rclpy.event_handler import QoSSubscriptionMatchedInfo, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ...files.atomic import atomic_folder
from ..plumbing.interfaces import message_class
from .metadata import (
    METADATA_FILE,
    TopicRecord,
    bag_metadata,
    message_definition,
    qos_metadata,
    type_hash,
)

#: Seconds between looks at the graph for new topics to record.
GRAPH_LOOK_PERIOD = 0.2


def offered_qos(node: Node, topic: str) -> QoSProfile:
    """The QoS that receives what every publisher of ``topic`` offers (rosbag2's rule).

    Reliable and transient local only when every publisher offers it: a
    stricter reader would not match a looser writer.
    """
    offers = node.get_publishers_info_by_topic(topic)
    reliable = bool(offers) and all(
        info.qos_profile.reliability == ReliabilityPolicy.RELIABLE for info in offers
    )
    latched = bool(offers) and all(
        info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for info in offers
    )
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


class Recorder(Node):
    """Records every topic under ``/NAMESPACE`` to a bag folder, written atomically on close."""

    def __init__(self, path: Path, namespace: str = "swarm", *, context: Context) -> None:
        super().__init__(
            "recorder",
            namespace=namespace,
            context=context,
            start_parameter_services=False,
            enable_rosout=False,
        )
        self.path = path
        self._prefix = f"/{namespace.strip('/')}/"
        # The folder and its atomic rename stay open until close(): a recording is
        # as long as the swarm runs.
        self._files = ExitStack()
        self._folder = self._files.enter_context(atomic_folder(path))
        self._storage = f"{path.name}_0.mcap"
        self._stream = self._files.enter_context((self._folder / self._storage).open("wb"))
        self._writer = Writer(self._stream)
        self._writer.start(profile="ros2", library="swazure")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}  # made at a topic's first message
        self._qos: dict[str, QoSProfile] = {}  # the recorder's own, per topic
        self._matched: dict[str, int] = {}
        self._topics: dict[str, TopicRecord] = {}
        self._first, self._last = 0, 0  # ns, of the first and the last message
        self.bytes = 0
        #: The bag is finished and at its path.
        self.closed = False
        #: Why recording stopped before the end (a full disk), in one line; None if it did not.
        self.stopped: str | None = None
        self._look()
        self.create_timer(GRAPH_LOOK_PERIOD, self._look)

    @property
    def counts(self) -> dict[str, int]:
        """Messages recorded per topic."""
        return {topic: record.count for topic, record in self._topics.items()}

    def _look(self) -> None:
        """Subscribe to the topics under the namespace whose publishers appeared since the last
        look. A topic seen through its readers alone waits for a publisher: subscribed then,
        it would get a best-effort, volatile reader for good, which loses messages under load
        and every latched one sent before it matched."""
        for topic, types in self.get_topic_names_and_types():
            if not topic.startswith(self._prefix) or topic in self._topics or len(types) != 1:
                continue
            if self.count_publishers(topic) > 0:
                self._record(topic, types[0])

    def _record(self, topic: str, type_name: str) -> None:
        qos = offered_qos(self, topic)
        if type_name not in self._schemas:
            definition = message_definition(type_name)
            self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding="ros2msg", data=definition.encode()
            )
        offers = [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
        self._topics[topic] = TopicRecord(type_name, type_hash(type_name), offers)
        self._qos[topic] = qos
        self._matched[topic] = 0

        def on_matched(status: QoSSubscriptionMatchedInfo, topic: str = topic) -> None:
            self._matched[topic] = status.current_count

        events = SubscriptionEventCallbacks(matched=on_matched)
        self.create_subscription(
            message_class(type_name),
            topic,
            partial(self._on_message, topic),
            qos,
            raw=True,
            event_callbacks=events,
        )

    def _on_message(self, topic: str, data: bytes) -> None:
        if self.closed or self.stopped is not None:
            return
        now = time.time_ns()
        record = self._topics[topic]
        record.count += 1
        self._first = self._first or now
        self._last = now
        self.bytes += len(data)
        try:
            self._writer.add_message(
                self._channel(topic), log_time=now, data=data, publish_time=now,
                sequence=record.count,
            )  # fmt: skip
        except OSError as err:
            record.count -= 1
            self._stop(err)

    def _stop(self, err: OSError) -> None:
        """Stop recording (a full disk): what was written stays, and the swarm runs on."""
        recorded = sum(self.counts.values())
        self.stopped = (
            f"{self.path}: recording stopped after {recorded} messages "
            f"({err.strerror or err}); the chunks written before are kept"
        )
        self.get_logger().error(self.stopped)  # type: ignore[no-untyped-call]

    def _channel(self, topic: str) -> int:
        """The MCAP channel of ``topic``, made at its first message with its publishers' QoS.

        Not earlier: a topic can show on the graph before its publishers' QoS
        does (a reader seen first), and a bag must offer what they offered.
        """
        channel = self._channels.get(topic)
        if channel is None:
            record, qos = self._offered(topic), self._qos[topic]
            channel = self._channels[topic] = self._writer.register_channel(
                topic=topic,
                message_encoding="cdr",
                schema_id=self._schemas[record.type_name],
                metadata={
                    **qos_metadata(qos, record.offers),
                    "topic_type_hash": record.type_hash,
                },
            )
        return channel

    def _offered(self, topic: str) -> TopicRecord:
        """``topic``'s record, its publishers' QoS filled in (the recorder's own if none)."""
        record = self._topics[topic]
        if not record.offers:
            publishers = self.get_publishers_info_by_topic(topic)
            record.offers = [info.qos_profile for info in publishers] or [self._qos[topic]]
        return record

    def caught_up(self) -> bool:
        """Whether every topic under the namespace is recorded from each of its publishers."""
        self._look()
        return all(self._matched[topic] >= self.count_publishers(topic) for topic in self._topics)

    def close(self) -> None:
        """Finish the bag and put it at its path (once)."""
        if self.closed:
            return
        self.closed = True
        for topic in self._topics:  # a topic that sent nothing: its publishers' QoS now
            self._offered(topic)
        metadata = bag_metadata(self._storage, self._topics, self._first, self._last)
        described = {"rosbag2_bagfile_information": metadata}
        try:
            for topic in self._topics:  # a topic that sent nothing is in the bag all the same
                self._channel(topic)
            # rosbag2's MCAP storage keeps the bag's metadata in the file too.
            self._writer.add_metadata(
                "rosbag2", {"serialized_metadata": yaml.safe_dump(metadata, sort_keys=False)}
            )
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._stream.close()
            (self._folder / METADATA_FILE).write_text(yaml.safe_dump(described, sort_keys=False))
        except OSError as err:
            if self.stopped is None:
                self._stop(err)
            # Kept as far as it was written: a reader takes it to its last whole chunk.
            # The buffer's tail is lost; the file is closed all the same.
            with contextlib.suppress(OSError):
                self._stream.close()
        self._files.close()  # the folder's rename into place
