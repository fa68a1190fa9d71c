"""What a recording says of itself: rosbag2's bag metadata, message schemas and offered QoS.

A recording is a bag folder as ``ros2 bag record -s mcap`` writes it (Jazzy,
metadata version 9): ``metadata.yaml`` (:func:`bag_metadata`) and one MCAP
file with the ``ros2`` profile's ``ros2msg`` schemas
(:func:`message_definition`) and ``cdr`` messages, each channel with its
publishers' ``offered_qos_profiles`` (:func:`qos_profiles`) and its
``topic_type_hash`` (:func:`type_hash`). The documents are typed records
(TypedDicts) of rosbag2's layout; a profile read back from a recording is
what the file says (:data:`OfferedProfile`).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

import yaml
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ...core.errors import SwazureError

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


class RosDuration(TypedDict):
    """A duration of a QoS profile as rosbag2 writes it: whole seconds, then nanoseconds."""

    sec: int
    nsec: int


class QosProfileDocument(TypedDict):
    """One publisher's QoS profile as rosbag2 (Jazzy) writes it: policies by name."""

    history: str
    depth: int
    reliability: str
    durability: str
    deadline: RosDuration
    lifespan: RosDuration
    liveliness: str
    liveliness_lease_duration: RosDuration
    avoid_ros_namespace_conventions: bool


#: rosbag2's "infinite" duration in a QoS profile (Jazzy's metadata writes it so).
_INFINITE: RosDuration = {"sec": 9223372036, "nsec": 854775807}

#: A publisher's QoS profile as a recording gives it back: rosbag2's policies by name (a
#: QosProfileDocument), or only ``reliability`` and ``durability`` in our first recordings,
#: or numbers in older rosbag2 metadata. Read from a file: its values are what the file says.
OfferedProfile = Mapping[str, object]


def qos_profiles(offers: list[QoSProfile]) -> list[QosProfileDocument]:
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
            "deadline": _INFINITE.copy(),
            "lifespan": _INFINITE.copy(),
            "liveliness": "automatic",
            "liveliness_lease_duration": _INFINITE.copy(),
            "avoid_ros_namespace_conventions": False,
        }
        for qos in offers
    ]


def qos_metadata(qos: QoSProfile, offers: list[QoSProfile]) -> dict[str, str]:
    """An MCAP channel's metadata of the QoS: its publishers' ``offers``, and the reader's
    ``qos`` as our first recordings said it."""
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


def offered_profiles(metadata: Mapping[str, str]) -> list[OfferedProfile]:
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


class Nanoseconds(TypedDict):
    """A duration in rosbag2's metadata."""

    nanoseconds: int


class SinceEpoch(TypedDict):
    """A time in rosbag2's metadata: ns since the epoch."""

    nanoseconds_since_epoch: int


class TopicMetadata(TypedDict):
    """A recorded topic as rosbag2's metadata describes it."""

    name: str
    type: str
    serialization_format: str
    offered_qos_profiles: list[QosProfileDocument]
    type_description_hash: str


class TopicCount(TypedDict):
    """A recorded topic and how many of its messages the bag holds."""

    topic_metadata: TopicMetadata
    message_count: int


class StorageFile(TypedDict):
    """One storage file of a bag: its name, times and message count."""

    path: str
    starting_time: SinceEpoch
    duration: Nanoseconds
    message_count: int


class BagMetadata(TypedDict):
    """rosbag2's bag metadata, version 9 (``rosbag2_bagfile_information`` in metadata.yaml)."""

    version: int
    storage_identifier: str
    duration: Nanoseconds
    starting_time: SinceEpoch
    message_count: int
    topics_with_message_count: list[TopicCount]
    compression_format: str
    compression_mode: str
    relative_file_paths: list[str]
    files: list[StorageFile]
    custom_data: None
    ros_distro: str


def bag_metadata(
    storage: str, topics: dict[str, TopicRecord], first: int, last: int
) -> BagMetadata:
    """rosbag2's bag metadata (version 9) of one MCAP file ``storage``; times in ns."""
    count = sum(topic.count for topic in topics.values())
    duration: Nanoseconds = {"nanoseconds": max(last - first, 0) if count else 0}
    starting: SinceEpoch = {"nanoseconds_since_epoch": first if count else 0}
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
