"""Recording a swarm run as a rosbag2 bag: every message the run sent, in a bag others read."""

from __future__ import annotations

import subprocess
import sys
from collections import Counter

import pytest
import yaml
from mcap.reader import make_reader
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from rosbags.highlevel import AnyReader
from swazure_interfaces.msg import Heartbeat, Measurements, PathOffer, PoseEstimates

from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.recording.metadata import type_hash
from swazure_ros.ros.recording.reader import read_recording, recorded_channels
from swazure_ros.ros.recording.recorder import Recorder

from ...conftest import REPO
from ...waits import PATIENCE, wait_until
from ..helpers import joined
from .conftest import RADIO, RUN_TOPICS, recorded_messages


def test_a_recorded_discovery_reads_back_every_message_the_run_sent(recorded_run, tmp_path):
    path, heard, result, world = recorded_run
    # Written whole at the path, a bag folder as ros2 bag writes it; nothing else beside it.
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]
    assert sorted(p.name for p in path.iterdir()) == ["metadata.yaml", "run_0.mcap"]
    channels = {channel.topic: channel for channel in recorded_channels(path)}
    recorded = recorded_messages(path)
    for topic in RUN_TOPICS:
        assert len(recorded[f"/swarm/{topic}"]) == result.traffic.messages[topic] > 0, topic
    offers = joined(recorded, RADIO)
    assert len(offers) == result.traffic.messages["radio"] > 0
    assert sorted(offers) == sorted(joined(heard, RADIO))
    # Every FLS's latched measurement, as the QoS it was offered with.
    sources = {
        deserialize_message(data, Measurements).source_id
        for data in recorded["/swarm/measurements"]
    }
    assert sources == set(world.ids.tolist())
    assert channels["/swarm/measurements"].metadata["durability"] == "transient_local"
    # rosbag2's own metadata: every FLS's publisher offered reliable and latched.
    offers = yaml.safe_load(channels["/swarm/measurements"].metadata["offered_qos_profiles"])
    assert len(offers) == len(world.ids)
    # (The graph tells no publisher's history or depth: as in rosbag2's own recordings.)
    assert {(o["reliability"], o["durability"]) for o in offers} == {
        ("reliable", "transient_local")
    }
    for topic in RADIO:
        radio = yaml.safe_load(channels[topic].metadata["offered_qos_profiles"])
        assert {(o["reliability"], o["durability"]) for o in radio} == {("reliable", "volatile")}
        assert channels[topic].type_name == "swazure_interfaces/msg/PathOffer"


def test_a_recording_is_a_bag_that_an_independent_rosbag2_reader_opens(recorded_run):
    path, _, result, world = recorded_run
    recorded = recorded_messages(path)
    channels = {channel.topic: channel for channel in recorded_channels(path)}
    with AnyReader([path]) as bag:
        connections = {connection.topic: connection for connection in bag.connections}
        # Every topic, with its type, type hash, message count and publishers' QoS.
        # (A topic that sent nothing during the run is in the bag with no message.)
        assert set(connections) == set(channels) >= set(recorded)
        for topic, connection in connections.items():
            assert connection.msgtype == channels[topic].type_name
            assert connection.msgcount == len(recorded.get(topic, [])), topic
            assert connection.digest == type_hash(connection.msgtype)
            assert connection.digest.startswith("RIHS01_")
            assert connection.ext.serialization_format == "cdr"
            assert connection.ext.offered_qos_profiles, topic
        for topic in RADIO:
            radio = connections[topic].ext.offered_qos_profiles
            assert {(qos.reliability.name, qos.durability.name) for qos in radio} == {
                ("RELIABLE", "VOLATILE")
            }
        latched = connections["/swarm/measurements"].ext.offered_qos_profiles
        assert len(latched) == len(world.ids)
        assert {qos.durability.name for qos in latched} == {"TRANSIENT_LOCAL"}
        count = sum(len(v) for v in recorded.values())
        assert bag.message_count == count
        # The bytes as recorded, and every message of every topic decoded by rosbags from
        # the bag's own schemas: each is its CDR exactly, the radio's offers too (rosbags
        # refuses a byte past a message's last field; docs/security.md, "What goes on the wire").
        cells = [connections[topic] for topic in RADIO]
        offers = [data for _, _, data in bag.messages(connections=cells)]
        assert sorted(offers) == sorted(joined(recorded, RADIO))
        for connection, _, data in bag.messages():
            decoded = bag.deserialize(data, connection.msgtype)
            assert decoded.__msgtype__ == connection.msgtype
        senders = Counter(
            bag.deserialize(data, "swazure_interfaces/msg/PathOffer").sender_id
            for _, _, data in bag.messages(connections=cells)
        )
        assert senders == Counter(
            deserialize_message(data, PathOffer).sender_id for data in offers
        )
        reports = bag.messages(connections=[connections["/swarm/estimates"]])
        sources = {
            bag.deserialize(data, "swazure_interfaces/msg/PoseEstimates").source_id
            for _, _, data in reports
        }
        assert sources == set(world.ids.tolist())
    assert len(joined(recorded, RADIO)) == result.traffic.messages["radio"]
    # The MCAP file alone is a recording too, with the same messages (our first form).
    assert recorded_messages(path / "run_0.mcap") == recorded
    with (path / "run_0.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
        metadata = dict(next(make_reader(stream).iter_metadata()).metadata)
    # rosbag2's MCAP storage reads the bag's metadata from the file, and MCAP's statistics.
    assert yaml.safe_load(metadata["serialized_metadata"])["message_count"] == count
    assert summary.statistics.message_count == count


def readme_block(heading):
    """The first ```python block of README.md's section ``heading``, as written there."""
    text = (REPO / "README.md").read_text()
    section = text[text.index(f"\n{heading}\n") :]
    return section.split("```python\n", 1)[1].split("\n```", 1)[0] + "\n"


def test_the_readmes_rosbags_block_decodes_a_recording_by_its_own_definitions(
    recorded_run, tmp_path
):
    path, _, _, world = recorded_run
    # The block reads results/run: the recorded bag, there.
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "run").symlink_to(path)
    script = tmp_path / "block.py"
    script.write_text(readme_block("### Read a bag in Python (rosbags)"))
    run = subprocess.run(
        [sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True,
        timeout=PATIENCE,
    )  # fmt: skip
    assert run.returncode == 0 and run.stderr == "", run.stderr
    # One line per source's report, as rclpy decodes the recorded bytes.
    reports = [
        (message.log_time, deserialize_message(message.data, PoseEstimates))
        for message in read_recording(path)
        if message.topic == "/swarm/estimates"
    ]
    expected = [f"{at} {r.source_id} {len(r.target_ids)} targets" for at, r in reports]
    assert run.stdout.splitlines() == expected
    assert {r.source_id for _, r in reports} == set(world.ids.tolist())


@pytest.fixture
def small_disk(tmp_path):
    """A 300 KiB file system (tmpfs), full long before a run's recording is done."""
    where = tmp_path / "disk"
    where.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=300k", "tmpfs", str(where)],
        capture_output=True, text=True,
    )  # fmt: skip
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({mounted.stderr.strip()}): needs root")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=False)


def test_a_full_disk_while_recording_keeps_the_results_and_what_was_written(
    small_disk, tmp_path, domain
):
    bag = small_disk / "bag"
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", "--cloud", "torus:120",
         "--scale", "1.6", "--beta", "0.5", "--quiet", "--domain-id", str(domain),
         "--record", str(bag), "--compute-all", "--out", str(tmp_path / "d")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    # The run's results, on another disk, are whole.
    assert "pairs identical to the engine's (status, path, estimate to 1e-9): yes" in run.stdout
    assert (tmp_path / "d" / "summary.json").is_file()
    # One line says where the recording stopped.
    (said,) = [line for line in run.stderr.splitlines() if line.startswith("swazure spawn:")]
    assert "recording stopped after" in said and "No space left on device" in said, said
    kept = int(said.split("recording stopped after ")[1].split(" ")[0])
    # What was written is at the bag's path, and replays to where it was cut.
    replay = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "replay", str(bag), "--delay", "0.01",
         "--rate", "1000", "--domain-id", str(domain)],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert "Traceback" not in replay.stderr, replay.stderr
    played = int(replay.stderr.split("cut short after message ")[1].split(";")[0])
    assert 0 < played <= kept, (played, kept)


def test_a_topic_seen_through_its_readers_first_is_recorded_as_its_publisher_offers(
    context, tmp_path
):
    # A reader of /swarm/latched shows the topic on the graph before any publisher does;
    # the recorder must wait for the publisher rather than take a best-effort, volatile
    # reader for good (which lost offers under load, and latched messages sent before it).
    latched = QoSProfile(
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )
    executor = SingleThreadedExecutor(context=context)
    reader = SwarmNode("early_reader", context=context)
    reader.create_subscription(Heartbeat, "/swarm/latched", lambda _: None, latched)
    recorder = Recorder(tmp_path / "bag", context=context)
    for node in (reader, recorder):
        executor.add_node(node)

    def spin() -> None:
        executor.spin_once(timeout_sec=0.05)

    def seen_by_recorder() -> bool:
        return "/swarm/latched" in dict(recorder.get_topic_names_and_types())

    assert wait_until(seen_by_recorder, PATIENCE, spin)
    for _ in range(10):  # a few of its looks at the graph with the reader alone
        spin()
    assert "/swarm/latched" not in recorder.counts
    writer = SwarmNode("late_writer", context=context)
    executor.add_node(writer)
    writer.create_publisher(Heartbeat, "/swarm/latched", latched).publish(Heartbeat())

    def recorded() -> bool:
        return recorder.counts.get("/swarm/latched", 0) == 1

    assert wait_until(recorded, PATIENCE, spin)
    (mine,) = [
        info
        for info in reader.get_subscriptions_info_by_topic("/swarm/latched")
        if info.node_name == "recorder"
    ]
    assert mine.qos_profile.reliability == ReliabilityPolicy.RELIABLE
    assert mine.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    recorder.close()
    for node in (reader, recorder, writer):
        node.destroy_node()
