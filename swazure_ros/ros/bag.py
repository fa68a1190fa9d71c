"""Recording a swarm's topics to MCAP, and playing a recording back, as ROS 2 CDR.

A raw subscription hands rclpy's callback the CDR bytes DDS carried, and a
publisher sends such bytes as they are, so a recording holds the wire's own
bytes: nothing is deserialised to record it or serialised to play it. The
file is MCAP with the ``ros2msg`` schemas and ``cdr`` encoding that
rosbag2's MCAP storage writes, so Foxglove and ``ros2 bag`` read it.

:class:`Recorder` subscribes to every topic under the swarm's namespace as
it appears on the graph (as ``ros2 bag record`` does), with the QoS its
publishers offer; :class:`Player` publishes a recording with its original
timing.
"""

from __future__ import annotations

import struct
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import yaml
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.writer import Writer
from rclpy.context import Context
from rclpy.event_handler import QoSSubscriptionMatchedInfo, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ..core.errors import SwazureError
from ..core.results import atomic_output
from .interfaces import message_class

#: Seconds between looks at the graph for new topics to record.
GRAPH_LOOK_PERIOD = 0.2
#: The primitive field types of the ROS 2 message language: no definition to add.
# fmt: off
PRIMITIVES = frozenset({
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
})
# fmt: on
_SEPARATOR = "=" * 80


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` schema of ``pkg/msg/Type``: its .msg text, then each type it uses.

    rosbag2's layout: every type used (directly or not) follows once, after a
    line of 80 ``=`` and ``MSG: pkg/Type``, so a reader can decode without an install.
    """
    package, _, name = type_name.split("/")
    texts = [_msg_text(package, name)]
    seen = {f"{package}/{name}"}
    pending = _used_types(texts[0], package)
    while pending:
        used = pending.pop(0)
        if used in seen:
            continue
        seen.add(used)
        used_package, used_name = used.split("/")
        text = _msg_text(used_package, used_name)
        texts.append(f"{_SEPARATOR}\nMSG: {used}\n{text}")
        pending += _used_types(text, used_package)
    return "\n".join(texts)


def _msg_text(package: str, name: str) -> str:
    try:
        share = Path(get_package_share_directory(package))
    except (PackageNotFoundError, ValueError, OSError):  # OSError: no AMENT_PREFIX_PATH
        # Installed from PyPI, the venv is an ament prefix that AMENT_PREFIX_PATH
        # need not name.
        share = Path(sys.prefix) / "share" / package
    try:
        return (share / "msg" / f"{name}.msg").read_text()
    except OSError as err:
        raise SwazureError(f"no message definition for {package}/msg/{name}") from err


def _used_types(text: str, package: str) -> list[str]:
    """The message types (pkg/Type) that fields of a .msg text use, in order."""
    used = []
    for line in text.splitlines():
        words = line.split("#", 1)[0].split()
        if len(words) < 2 or "=" in words[1]:
            continue  # blank, comment, or a constant
        field_type = words[0].split("[", 1)[0].split("<=", 1)[0]
        if field_type in PRIMITIVES:
            continue
        if "/" not in field_type:
            field_type = "std_msgs/Header" if field_type == "Header" else f"{package}/{field_type}"
        used.append(field_type.replace("/msg/", "/"))
    return used


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


#: rosbag2's "infinite" duration in a QoS profile (Jazzy's metadata writes it so).
_INFINITE = {"sec": 9223372036, "nsec": 854775807}


def offered_qos_profiles(offers: list[QoSProfile]) -> str:
    """rosbag2's channel metadata ``offered_qos_profiles``: the publishers' QoS, YAML.

    As Jazzy's rosbag2 writes it (policies by name), so that ``ros2 bag
    play`` offers a latched topic latched again.
    """
    profiles = [
        {
            "history": "keep_all" if qos.history == HistoryPolicy.KEEP_ALL else "keep_last",
            "depth": int(qos.depth),
            "reliability": "reliable"
            if qos.reliability == ReliabilityPolicy.RELIABLE
            else "best_effort",
            "durability": "transient_local"
            if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL
            else "volatile",
            "deadline": dict(_INFINITE),
            "lifespan": dict(_INFINITE),
            "liveliness": "automatic",
            "liveliness_lease_duration": dict(_INFINITE),
            "avoid_ros_namespace_conventions": False,
        }
        for qos in offers
    ]
    return yaml.safe_dump(profiles, sort_keys=False)


def _qos_metadata(qos: QoSProfile, offers: list[QoSProfile]) -> dict[str, str]:
    return {
        "offered_qos_profiles": offered_qos_profiles(offers or [qos]),
        # Our first recordings' keys, kept for the readers of those.
        "reliability": "reliable"
        if qos.reliability == ReliabilityPolicy.RELIABLE
        else "best_effort",
        "durability": (
            "transient_local" if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL else "volatile"
        ),
    }


class Recorder(Node):
    """Records every topic under ``/NAMESPACE`` to an MCAP file, written atomically on close."""

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
        # The file and its atomic rename stay open until close(): a recording is
        # as long as the swarm runs.
        self._files = ExitStack()
        temporary = self._files.enter_context(atomic_output(path))
        self._writer = Writer(self._files.enter_context(temporary.open("wb")))
        self._writer.start(profile="ros2", library="swazure")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._matched: dict[str, int] = {}
        #: Messages recorded per topic.
        self.counts: dict[str, int] = {}
        self.bytes = 0
        #: The file is finished and at its path.
        self.closed = False
        self._look()
        self.create_timer(GRAPH_LOOK_PERIOD, self._look)

    def _look(self) -> None:
        """Subscribe to the topics under the namespace that appeared since the last look."""
        for topic, types in self.get_topic_names_and_types():
            if not topic.startswith(self._prefix) or topic in self._channels or len(types) != 1:
                continue
            self._record(topic, types[0])

    def _record(self, topic: str, type_name: str) -> None:
        qos = offered_qos(self, topic)
        if type_name not in self._schemas:
            definition = message_definition(type_name)
            self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding="ros2msg", data=definition.encode()
            )
        self._channels[topic] = self._writer.register_channel(
            topic=topic,
            message_encoding="cdr",
            schema_id=self._schemas[type_name],
            metadata=_qos_metadata(
                qos, [info.qos_profile for info in self.get_publishers_info_by_topic(topic)]
            ),
        )
        self.counts[topic] = 0
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
        if self.closed:
            return
        now = time.time_ns()
        self.counts[topic] += 1
        self.bytes += len(data)
        self._writer.add_message(
            self._channels[topic], log_time=now, data=data, publish_time=now,
            sequence=self.counts[topic],
        )  # fmt: skip

    def caught_up(self) -> bool:
        """Whether every topic under the namespace is recorded from each of its publishers."""
        self._look()
        return all(
            self._matched[topic] >= self.count_publishers(topic) for topic in self._channels
        )

    def close(self) -> None:
        """Finish the file and put it at its path (once)."""
        if self.closed:
            return
        self.closed = True
        self._writer.finish()  # type: ignore[no-untyped-call]
        self._files.close()  # the stream, then the rename into place


@dataclass(frozen=True)
class Channel:
    """One recorded topic: its type (pkg/msg/Type) and QoS as recorded."""

    topic: str
    type_name: str
    metadata: dict[str, str]


@dataclass(frozen=True)
class Recorded:
    """One message of a recording: its topic, CDR bytes, and when it was logged (ns)."""

    topic: str
    data: bytes
    log_time: int


def recorded_channels(path: Path) -> list[Channel]:
    """The ROS 2 (cdr) topics of an MCAP recording; SwazureError if it is not one."""
    try:
        with path.open("rb") as stream:
            summary = make_reader(stream).get_summary()
    except OSError as err:
        raise SwazureError(f"{path}: cannot read ({err.strerror or err})") from err
    except (McapError, ValueError, EOFError, struct.error) as err:
        raise SwazureError(f"{path}: not an MCAP recording ({err})") from err
    if summary is None:
        raise SwazureError(f"{path}: not a finished MCAP recording (no summary)")
    return [
        Channel(channel.topic, summary.schemas[channel.schema_id].name, dict(channel.metadata))
        for channel in summary.channels.values()
        if channel.message_encoding == "cdr" and channel.schema_id in summary.schemas
    ]


def read_recording(path: Path) -> Iterator[Recorded]:
    """The ROS 2 messages of an MCAP recording, in log time order."""
    try:
        with path.open("rb") as stream:
            messages = make_reader(stream).iter_messages(log_time_order=True)
            for schema, channel, message in messages:
                if schema is not None and channel.message_encoding == "cdr":
                    yield Recorded(channel.topic, message.data, message.log_time)
    except OSError as err:
        raise SwazureError(f"{path}: cannot read ({err.strerror or err})") from err
    except (McapError, ValueError, EOFError, struct.error) as err:
        raise SwazureError(f"{path}: not an MCAP recording ({err})") from err


class Player(Node):
    """Publishes recorded messages on their topics, with the QoS they were recorded with."""

    def __init__(self, channels: list[Channel], *, context: Context) -> None:
        super().__init__(
            "player", context=context, start_parameter_services=False, enable_rosout=False
        )
        self._by_topic: dict[str, Publisher] = {}
        for channel in channels:
            try:
                kind: Any = message_class(channel.type_name)
            except SwazureError as err:
                raise SwazureError(f"{channel.topic}: {err}") from err
            self._by_topic[channel.topic] = self.create_publisher(
                kind, channel.topic, _qos_of(channel.metadata)
            )

    def play(self, message: Recorded) -> None:
        """Publish ``message``'s bytes as they were recorded."""
        self._by_topic[message.topic].publish(message.data)


def _qos_of(metadata: dict[str, str]) -> QoSProfile:
    """The publisher QoS of a recorded topic: rosbag2's rule over the offered profiles.

    Reliable and latched when every publisher offered it; from our first
    recordings' own keys where there are no profiles (reliable, volatile when
    not said).
    """
    offers = yaml.safe_load(metadata.get("offered_qos_profiles", "")) or []
    if isinstance(offers, list) and offers and all(isinstance(o, dict) for o in offers):
        reliable = all(o.get("reliability") in ("reliable", 1) for o in offers)
        latched = all(o.get("durability") in ("transient_local", 1) for o in offers)
    else:
        reliable = metadata.get("reliability", "reliable") == "reliable"
        latched = metadata.get("durability") == "transient_local"
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )
