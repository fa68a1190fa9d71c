"""Recording a swarm's topics as a rosbag2 bag, and playing a recording back, as ROS 2 CDR.

A raw subscription hands rclpy's callback the CDR bytes DDS carried, and a
publisher sends such bytes as they are, so a recording holds the wire's own
bytes: nothing is deserialised to record it or serialised to play it.

A recording is a bag folder as ``ros2 bag record -s mcap`` writes it (Jazzy,
metadata version 9): ``metadata.yaml`` and one MCAP file with the ``ros2``
profile's ``ros2msg`` schemas and ``cdr`` messages, each channel with its
publishers' ``offered_qos_profiles`` and its ``topic_type_hash``, rosbag2's
``rosbag2`` metadata record and MCAP's statistics. ``ros2 bag info`` and
``play``, rosbags and Foxglove read it. A single ``.mcap`` file (our first
recordings) is read as well.

:class:`Recorder` subscribes to every topic under the swarm's namespace as
it appears on the graph (as ``ros2 bag record`` does), with the QoS its
publishers offer; :class:`Player` publishes a recording with its original
timing; :func:`bag_info` tells what a recording holds (``swazure replay
--info``, as ``ros2 bag info``).
"""

from __future__ import annotations

import contextlib
import json
import struct
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from functools import partial
from pathlib import Path, PurePath
from typing import Any

import yaml
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import NonSeekingReader, make_reader
from mcap.records import Channel as McapChannel
from mcap.records import Schema
from mcap.stream_reader import StreamReader
from mcap.writer import Writer
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.event_handler import QoSSubscriptionMatchedInfo, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ...core.errors import SwazureError
from ...files.atomic import atomic_folder
from ...files.reading import read_yaml, regular_file
from ..plumbing.interfaces import message_class

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


def _share(package: str) -> Path:
    """The share/ folder of an interface package."""
    try:
        return Path(get_package_share_directory(package))
    except (PackageNotFoundError, ValueError, OSError):  # OSError: no AMENT_PREFIX_PATH
        # Installed from PyPI, the venv is an ament prefix that AMENT_PREFIX_PATH
        # need not name.
        return Path(sys.prefix) / "share" / package


def _msg_text(package: str, name: str) -> str:
    share = _share(package)
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


def qos_profiles(offers: list[QoSProfile]) -> list[dict[str, Any]]:
    """The publishers' QoS as rosbag2 describes them: Jazzy's layout, policies by name.

    So that ``ros2 bag play`` offers a latched topic latched again. A bag's
    metadata.yaml holds the list; an MCAP channel's metadata, its YAML text.
    """
    return [
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


def _qos_metadata(qos: QoSProfile, offers: list[QoSProfile]) -> dict[str, str]:
    return {
        "offered_qos_profiles": yaml.safe_dump(qos_profiles(offers), sort_keys=False),
        # Our first recordings' keys, kept for the readers of those.
        "reliability": "reliable"
        if qos.reliability == ReliabilityPolicy.RELIABLE
        else "best_effort",
        "durability": (
            "transient_local" if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL else "volatile"
        ),
    }


#: rosbag2's metadata version that Jazzy writes (offered QoS profiles as YAML lists).
BAG_VERSION = 9
#: The bag folder's description file.
METADATA_FILE = "metadata.yaml"


def type_hash(type_name: str) -> str:
    """The RIHS01 type hash of ``pkg/msg/Type``, from its installed type description."""
    package, _, name = type_name.split("/")
    path = _share(package) / "msg" / f"{name}.json"
    try:
        hashes = json.loads(path.read_text())["type_hashes"]
        return str(next(h["hash_string"] for h in hashes if h["type_name"] == type_name))
    except (OSError, ValueError, KeyError, TypeError, StopIteration) as err:
        raise SwazureError(f"no type description for {type_name} ({path})") from err


@dataclass
class TopicRecord:
    """What a bag says of one recorded topic: its type, hash, publishers' QoS and count."""

    type_name: str
    type_hash: str
    offers: list[QoSProfile]
    count: int = 0


def bag_metadata(
    storage: str, topics: dict[str, TopicRecord], first: int, last: int
) -> dict[str, Any]:
    """rosbag2's bag metadata (version 9) of one MCAP file ``storage``; times in ns."""
    count = sum(topic.count for topic in topics.values())
    duration = {"nanoseconds": max(last - first, 0) if count else 0}
    starting = {"nanoseconds_since_epoch": first if count else 0}
    return {
        "version": BAG_VERSION,
        "storage_identifier": "mcap",
        "duration": duration,
        "starting_time": starting,
        "message_count": count,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": name,
                    "type": topic.type_name,
                    "serialization_format": "cdr",
                    "offered_qos_profiles": qos_profiles(topic.offers),
                    "type_description_hash": topic.type_hash,
                },
                "message_count": topic.count,
            }
            for name, topic in topics.items()
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [storage],
        "files": [
            {
                "path": storage,
                "starting_time": starting,
                "duration": duration,
                "message_count": count,
            }
        ],
        "custom_data": None,
        "ros_distro": "jazzy",
    }


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
        """Subscribe to the topics under the namespace that appeared since the last look."""
        for topic, types in self.get_topic_names_and_types():
            if not topic.startswith(self._prefix) or topic in self._topics or len(types) != 1:
                continue
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
                    **_qos_metadata(qos, record.offers),
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


def storage_files(path: Path) -> list[Path]:
    """The MCAP files of a recording: a bag folder's (its metadata.yaml says), or ``path``.

    Each is a regular file, or SwazureError in one line: a FIFO would block its reader.
    """
    return [regular_file(storage, "recording", None, SwazureError) for storage in _storage(path)]


def _storage(path: Path) -> list[Path]:
    if not path.is_dir():
        return [path]
    if not (path / METADATA_FILE).exists():
        # A recording stopped by a full disk: its file, as far as it was written.
        partial = sorted(path.glob("*.mcap"))
        if partial:
            return partial
    described = read_yaml(path / METADATA_FILE, "bag metadata", SwazureError)
    try:
        metadata = described["rosbag2_bagfile_information"]
        if metadata["storage_identifier"] != "mcap":
            raise SwazureError(
                f"{path}: a bag of {metadata['storage_identifier']!r} storage; "
                "recordings here are MCAP"
            )
        # A bag's files are beside its metadata, by name (as rosbag2 reads them).
        return [path / PurePath(str(name)).name for name in metadata["relative_file_paths"]]
    except (KeyError, TypeError) as err:
        raise SwazureError(f"{path}: not a rosbag2 bag ({METADATA_FILE} lacks {err})") from err


def recorded_channels(path: Path) -> list[Channel]:
    """The ROS 2 (cdr) topics of a recording; SwazureError if it is not one."""
    channels: dict[str, Channel] = {}
    for storage in storage_files(path):
        try:
            with storage.open("rb") as stream:
                summary = make_reader(stream).get_summary()
        except OSError as err:
            raise SwazureError(f"{storage}: cannot read ({err.strerror or err})") from err
        except Exception as err:  # a corrupted summary: the decoders raise what they raise
            # Cut short (a full disk): its schemas and channels as far as it was written.
            schemas, found = _written_channels(storage)
            if not found:
                plain = isinstance(err, (McapError, ValueError, EOFError, struct.error))
                raise SwazureError(
                    f"{storage}: not an MCAP recording ({err})"
                    if plain
                    else f"{storage}: a corrupted MCAP summary ({type(err).__name__}: {err})"
                ) from err
        else:
            if summary is None:
                schemas, found = _written_channels(storage)
                if not found:
                    raise SwazureError(f"{storage}: not a finished MCAP recording (no summary)")
            else:
                schemas, found = summary.schemas, list(summary.channels.values())
        for channel in found:
            if channel.message_encoding == "cdr" and channel.schema_id in schemas:
                schema = schemas[channel.schema_id].name
                channels[channel.topic] = Channel(channel.topic, schema, dict(channel.metadata))
    return list(channels.values())


def _written_channels(storage: Path) -> tuple[dict[int, Any], list[Any]]:
    """The schemas (by id) and channels an MCAP file without a summary holds, read in order."""
    schemas: dict[int, Any] = {}
    channels: list[Any] = []
    with storage.open("rb") as stream:
        try:
            for record in StreamReader(stream, skip_magic=False, validate_crcs=True).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, McapChannel):
                    channels.append(record)
        except Exception:  # the end of what was written: the decoders raise what they raise
            pass
    return schemas, channels


def read_recording(path: Path) -> Iterator[Recorded]:
    """The ROS 2 messages of a recording, file by file, in log time order.

    A file corrupted on the way stops the messages at its last good chunk:
    SwazureError then says after how many and why.
    """
    read = 0
    for storage in storage_files(path):
        try:
            with storage.open("rb") as stream:
                # Checked chunk by chunk: damaged bytes end the messages, not change them.
                reader = make_reader(stream, validate_crcs=True)
                # A file cut short (a full disk) has no summary to order its chunks by:
                # it is read as written, which is in log time order.
                ordered = _has_summary(reader)
                stream.seek(0)
                if not ordered:
                    reader = NonSeekingReader(stream, validate_crcs=True)
                messages = reader.iter_messages(log_time_order=ordered)
                for schema, channel, message in messages:
                    if schema is not None and channel.message_encoding == "cdr":
                        yield Recorded(channel.topic, message.data, message.log_time)
                        read += 1
        except OSError as err:
            raise SwazureError(f"{storage}: cannot read ({err.strerror or err})") from err
        except EndOfFile as err:  # written until it could not be (a full disk)
            raise SwazureError(f"{storage}: cut short after message {read}") from err
        except Exception as err:  # a corrupted chunk: CRC, decompression, indexes
            raise SwazureError(
                f"{storage}: corrupted after message {read} ({type(err).__name__}: {err})"
            ) from err


def _has_summary(reader: Any) -> bool:
    """Whether an MCAP reader's file ends with a readable summary."""
    try:
        return reader.get_summary() is not None
    except Exception:  # a footer or summary cut short: the decoders raise what they raise
        return False


@dataclass(frozen=True)
class TopicInfo:
    """One recorded topic, as ``ros2 bag info`` lists it.

    ``offered_qos`` is rosbag2's list of its publishers' QoS profiles, one per
    publisher, policies by name (``reliability``, ``durability``, ...).
    """

    name: str
    type_name: str
    count: int
    serialization_format: str
    offered_qos: list[dict[str, Any]]


@dataclass(frozen=True)
class BagInfo:
    """What a recording holds, as ``ros2 bag info`` tells it; times in ns since the epoch.

    From the bag's metadata.yaml, or for an MCAP file alone (or a bag cut short
    before its metadata was written) from the file's statistics, or by reading it
    where it has none; ``cut`` then says where its messages end.
    """

    path: Path
    files: list[Path]
    size: int  # bytes, of its storage files
    storage: str
    ros_distro: str
    start: int
    duration: int  # ns
    count: int
    topics: list[TopicInfo]
    cut: str | None = None

    @property
    def end(self) -> int:
        """When the last message was logged, ns since the epoch."""
        return self.start + self.duration


def bag_info(path: Path) -> BagInfo:
    """What the recording at ``path`` holds; SwazureError in one line if it is not one.

    A bag folder is described by its metadata.yaml, as ``ros2 bag info`` does;
    its storage files must be there.
    """
    files = storage_files(path)
    size = sum(storage.stat().st_size for storage in files)
    if path.is_dir() and (path / METADATA_FILE).exists():
        described = read_yaml(path / METADATA_FILE, "bag metadata", SwazureError)
        try:
            return _described_info(path, files, size, described["rosbag2_bagfile_information"])
        except KeyError as err:
            raise SwazureError(f"{path}: not a rosbag2 bag ({METADATA_FILE} lacks {err})") from err
        except (TypeError, ValueError, AttributeError, yaml.YAMLError) as err:
            raise SwazureError(f"{path}: not a rosbag2 bag ({METADATA_FILE}: {err})") from err
    return _mcap_info(path, files, size)


def _described_info(path: Path, files: list[Path], size: int, metadata: Any) -> BagInfo:
    """A bag's info from rosbag2's metadata (version 9; older ones keep QoS as YAML text)."""
    topics = []
    for entry in metadata["topics_with_message_count"]:
        topic = entry["topic_metadata"]
        offered = topic.get("offered_qos_profiles") or []
        if isinstance(offered, str):
            offered = yaml.safe_load(offered) or []
        topics.append(
            TopicInfo(
                str(topic["name"]), str(topic["type"]), int(entry["message_count"]),
                str(topic.get("serialization_format", "cdr")), list(offered),
            )
        )  # fmt: skip
    return BagInfo(
        path=path,
        files=files,
        size=size,
        storage=str(metadata["storage_identifier"]),
        ros_distro=str(metadata.get("ros_distro") or "-"),
        start=int(metadata["starting_time"]["nanoseconds_since_epoch"]),
        duration=int(metadata["duration"]["nanoseconds"]),
        count=int(metadata["message_count"]),
        topics=topics,
    )


def _mcap_info(path: Path, files: list[Path], size: int) -> BagInfo:
    """An MCAP recording's info from its statistics, or counted message by message."""
    channels = recorded_channels(path)
    counts = dict.fromkeys((channel.topic for channel in channels), 0)
    times: list[int] = []
    cut = None
    for storage in files:
        with storage.open("rb") as stream:
            reader = make_reader(stream)
            summary = reader.get_summary() if _has_summary(reader) else None
        statistics = summary.statistics if summary is not None else None
        if statistics is not None and summary is not None:
            for channel_id, count in statistics.channel_message_counts.items():
                channel = summary.channels.get(channel_id)
                if channel is not None and channel.topic in counts:
                    counts[channel.topic] += count
            if statistics.message_count:
                times += [statistics.message_start_time, statistics.message_end_time]
            continue
        try:  # no statistics (a file cut short): its messages, as far as they go
            for message in read_recording(storage):
                counts[message.topic] = counts.get(message.topic, 0) + 1
                times.append(message.log_time)
        except SwazureError as err:
            cut = str(err)
    by_topic = {channel.topic: channel for channel in channels}
    topics = [
        TopicInfo(
            topic, by_topic[topic].type_name, count, "cdr",
            _offered_profiles(by_topic[topic].metadata),
        )
        for topic, count in counts.items()
    ]  # fmt: skip
    start = min(times, default=0)
    return BagInfo(
        path=path, files=files, size=size, storage="mcap", ros_distro="-", start=start,
        duration=max(times, default=0) - start, count=sum(counts.values()), topics=topics,
        cut=cut,
    )  # fmt: skip


def _offered_profiles(metadata: dict[str, str]) -> list[dict[str, Any]]:
    """A recorded channel's offered QoS profiles: rosbag2's YAML list, or one from our
    first recordings' own keys (reliable, volatile when not said); [] without either."""
    try:
        offered = yaml.safe_load(metadata.get("offered_qos_profiles", "")) or []
    except yaml.YAMLError:
        offered = None  # a corrupted record: the keys below
    if offered and isinstance(offered, list) and all(isinstance(o, dict) for o in offered):
        return offered
    if "reliability" in metadata or "durability" in metadata:
        return [
            {
                "reliability": metadata.get("reliability", "reliable"),
                "durability": metadata.get("durability", "volatile"),
            }
        ]
    return []


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

    def unacknowledged(self, timeout: float) -> list[str]:
        """The topics whose reliable readers have not acknowledged every message within
        ``timeout`` s (all of them waited for at once)."""
        deadline = time.monotonic() + timeout
        return [
            topic
            for topic, publisher in self._by_topic.items()
            if not publisher.wait_for_all_acked(
                Duration(seconds=max(deadline - time.monotonic(), 0.0))
            )
        ]


def _qos_of(metadata: dict[str, str]) -> QoSProfile:
    """The publisher QoS of a recorded topic: rosbag2's rule over the offered profiles.

    Reliable and latched when every publisher offered it; from our first
    recordings' own keys where there are no profiles (reliable, volatile when
    not said).
    """
    offers = _offered_profiles(metadata)  # none: reliable and volatile
    reliable = all(o.get("reliability") in ("reliable", 1) for o in offers)
    latched = bool(offers) and all(o.get("durability") in ("transient_local", 1) for o in offers)
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )
