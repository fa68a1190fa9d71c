"""What a recording says of itself: schemas, its publishers' QoS, rosbag2's metadata."""

from __future__ import annotations

from geometry_msgs.msg import Vector3
from mcap_ros2.decoder import generate_dynamic
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from swazure_interfaces.msg import Measurements, RelativePose

from swazure_ros.ros.recording.metadata import (
    TopicRecord,
    bag_metadata,
    message_definition,
    offered_profiles,
    qos_metadata,
)


def test_a_message_definition_holds_every_type_used_once_and_decodes_without_an_install():
    text = message_definition("swazure_interfaces/msg/Measurements")
    for used in (
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "swazure_interfaces/RelativePose",
        "geometry_msgs/Vector3",
    ):
        assert text.count(f"MSG: {used}\n") == 1, used
    pose = RelativePose(source_id=7, target_id=9, range_class=RelativePose.RANGE_SWEET)
    pose.line_of_sight, pose.tracking_distance = True, 0.5
    pose.vector = Vector3(x=1.5, y=-2.0, z=0.25)
    sent = Measurements(source_id=7, poses=[pose])
    # What Foxglove does: build a decoder from the schema text alone.
    decode = generate_dynamic("swazure_interfaces/msg/Measurements", text)
    got = decode["swazure_interfaces/msg/Measurements"](serialize_message(sent))
    assert got.source_id == 7 and len(got.poses) == 1
    assert (got.poses[0].target_id, got.poses[0].range_class) == (9, RelativePose.RANGE_SWEET)
    assert (got.poses[0].vector.x, got.poses[0].vector.y, got.poses[0].vector.z) == (
        1.5,
        -2.0,
        0.25,
    )


def test_offered_profiles_read_back_what_the_recorder_writes_and_our_first_recordings_keys():
    latched = QoSProfile(
        depth=1, reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )  # fmt: skip
    volatile = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    profiles = offered_profiles(qos_metadata(latched, [latched, volatile]))
    assert [(p["reliability"], p["durability"], p["depth"]) for p in profiles] == [
        ("reliable", "transient_local", 1),
        ("best_effort", "volatile", 10),
    ]
    # rosbag2's infinite durations, as Jazzy writes them.
    assert profiles[0]["deadline"] == {"sec": 9223372036, "nsec": 854775807}
    # Our first recordings kept the reader's own keys only: reliable and volatile if unsaid.
    assert offered_profiles({"reliability": "best_effort"}) == [
        {"reliability": "best_effort", "durability": "volatile"}
    ]
    corrupted = {"offered_qos_profiles": "hello: [", "durability": "transient_local"}
    assert offered_profiles(corrupted) == [
        {"reliability": "reliable", "durability": "transient_local"}
    ]
    assert offered_profiles({}) == []


def test_bag_metadata_counts_every_topic_and_has_no_times_without_a_message():
    def record(count: int) -> TopicRecord:
        return TopicRecord("geometry_msgs/msg/Vector3", "RIHS01_0", [], count)

    metadata = bag_metadata("run_0.mcap", {"/a": record(3), "/b": record(0)}, first=10, last=25)
    assert metadata["version"] == 9 and metadata["storage_identifier"] == "mcap"
    assert metadata["message_count"] == 3
    assert metadata["duration"] == {"nanoseconds": 15}
    assert metadata["starting_time"] == {"nanoseconds_since_epoch": 10}
    counts = [(t["topic_metadata"]["name"], t["message_count"])
              for t in metadata["topics_with_message_count"]]  # fmt: skip
    assert counts == [("/a", 3), ("/b", 0)]
    assert metadata["relative_file_paths"] == ["run_0.mcap"]
    assert metadata["files"][0]["path"] == "run_0.mcap"
    assert metadata["files"][0]["message_count"] == 3
    # A bag of topics that sent nothing starts and lasts 0, whatever the clock said.
    empty = bag_metadata("run_0.mcap", {"/b": record(0)}, first=10, last=25)
    assert empty["duration"] == {"nanoseconds": 0}
    assert empty["starting_time"] == {"nanoseconds_since_epoch": 0}
