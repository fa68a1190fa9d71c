"""Reading a recording back: its topics, its messages in log time order, what it holds.

A recording is a bag folder (:mod:`.metadata`: its layout) or a single
``.mcap`` file (our first recordings). :func:`read_recording` gives its
messages as the CDR bytes that were recorded, :func:`recorded_channels` its
topics with the QoS they were recorded with, and :func:`bag_info` what it
holds (``swazure replay --info``, as ``ros2 bag info``). A recording cut
short (a full disk) or corrupted on the way is read as far as it goes.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Any

import yaml
from mcap.exceptions import EndOfFile, McapError
from mcap.reader import McapReader, NonSeekingReader, make_reader
from mcap.records import Channel as McapChannel
from mcap.records import Schema
from mcap.stream_reader import StreamReader

from ...core.errors import SwazureError
from ...files.reading import read_yaml, regular_file
from .metadata import METADATA_FILE, OfferedProfile, offered_profiles


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


def _written_channels(storage: Path) -> tuple[dict[int, Schema], list[McapChannel]]:
    """The schemas (by id) and channels an MCAP file without a summary holds, read in order."""
    schemas: dict[int, Schema] = {}
    channels: list[McapChannel] = []
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


def _has_summary(reader: McapReader) -> bool:
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
    offered_qos: list[OfferedProfile]


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
            offered_profiles(by_topic[topic].metadata),
        )
        for topic, count in counts.items()
    ]  # fmt: skip
    start = min(times, default=0)
    return BagInfo(
        path=path, files=files, size=size, storage="mcap", ros_distro="-", start=start,
        duration=max(times, default=0) - start, count=sum(counts.values()), topics=topics,
        cut=cut,
    )  # fmt: skip
