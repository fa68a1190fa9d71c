"""Recording a swarm run as a rosbag2 bag and playing it back: what was sent is what is read."""

from __future__ import annotations

import contextlib
import subprocess
import sys
from collections import defaultdict
from functools import partial

import pytest
import yaml
from geometry_msgs.msg import Vector3
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_ros2.decoder import generate_dynamic
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader
from swazure_interfaces.msg import Measurements, PathOffer, PoseEstimates, RelativePose

from swazure_ros.app.config import SwarmConfig
from swazure_ros.app.swarm import RunningSwarm
from swazure_ros.core.errors import SwazureError
from swazure_ros.ros.plumbing.names import ROUND_QOS
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.recording.metadata import message_definition, type_hash
from swazure_ros.ros.recording.reader import bag_info, read_recording, recorded_channels
from swazure_ros.sim.world import WorldSpec

from ...conftest import REPO
from ...waits import PATIENCE, wait_until
from ..helpers import joined, radio_topics

WORLD = WorldSpec("helix:60", beta=0.5)
KEEP_ALL_LATCHED = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
#: The protocol's topics of a discovery run, as the coordinator counts them.
RUN_TOPICS = ("estimates", "round_acks", "discovery")
RADIO = radio_topics(WORLD)


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


class Probe:
    """A raw subscriber to some topics of the swarm, keeping every message's bytes."""

    def __init__(self, context, topics):
        self.node = SwarmNode("probe", context=context)
        self.received = defaultdict(list)
        self.subscriptions = [
            self.node.create_subscription(kind, topic, partial(self._on, topic), qos, raw=True)
            for topic, kind, qos in topics
        ]

    def matched(self) -> bool:
        """Every subscription is matched to a publisher: what is sent now reaches it."""
        return all(one.get_publisher_count() >= 1 for one in self.subscriptions)

    def _on(self, topic, data):
        self.received[topic].append(data)


def recorded_messages(path):
    received = defaultdict(list)
    for message in read_recording(path):
        received[message.topic].append(message.data)
    return received


@pytest.fixture
def recorded_run(domain, tmp_path):
    """A helix swarm's discovery, recorded; with what a probe heard and the run's traffic."""
    path = tmp_path / "run"
    config = SwarmConfig(WORLD, domain_id=domain, record=str(path))
    with RunningSwarm.start(config) as swarm:
        probe = Probe(swarm.context, [(topic, PathOffer, ROUND_QOS) for topic in RADIO])
        swarm.host.add(probe.node)
        assert wait_until(probe.matched, PATIENCE, lambda: swarm.spin(0.05))
        result = swarm.discover("shortest-length", timeout=PATIENCE)
        # The run's last messages reach every reader, and every FLS's latched measurement
        # the recorder, however late its publisher matched.
        recorder = swarm.recorder
        assert recorder is not None

        def everything_arrived() -> bool:
            offers = result.traffic.messages["radio"]
            recorded = sum(recorder.counts.get(topic, 0) for topic in RADIO)
            return (
                len(joined(probe.received, RADIO)) >= offers
                and recorded >= offers
                and recorder.counts.get("/swarm/measurements", 0) >= len(swarm.world.ids)
            )

        assert wait_until(everything_arrived, PATIENCE, lambda: swarm.spin(0.05))
        # Still recording: nothing is at the path until the swarm stops.
        assert not path.exists()
    return path, probe.received, result, swarm.world


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
        # The bytes as recorded, and decoded by rosbags from the bag's own schemas. (Not the
        # radio's offers: rmw_fastrtps's serialize_message pads some of them past their CDR
        # end with stray bytes, which rosbags refuses and every ROS 2 reader ignores.)
        cells = [connections[topic] for topic in RADIO]
        offers = [data for _, _, data in bag.messages(connections=cells)]
        assert sorted(offers) == sorted(joined(recorded, RADIO))
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


def replay_info(path):
    """``swazure replay --info path``: its exit code, output and error text."""
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "replay", "--info", str(path)],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    return run.returncode, run.stdout, run.stderr


def info_topics(text):
    """Topic -> its fields (Type, Count, Offered QoS...) from ``replay --info``'s lines."""
    topics = {}
    for line in text.splitlines():
        if "Topic: " in line:
            fields = dict(part.split(": ", 1) for part in line.split("Topic: ", 1)[1:])
            fields.update(dict(part.split(": ", 1) for part in line.split(" | ")[1:]))
            topics[line.split("Topic: ", 1)[1].split(" | ")[0]] = fields
    return topics


def test_replay_info_tells_what_a_bag_holds_as_an_independent_reader_reads_it(recorded_run):
    path, _, _, world = recorded_run
    code, out, err = replay_info(path)
    assert code == 0 and err == "", err
    said = info_topics(out)
    with Reader(path) as bag:  # rosbags, from the bag's own metadata
        assert set(said) == {connection.topic for connection in bag.connections}
        for connection in bag.connections:
            topic = said[connection.topic]
            assert topic["Type"] == connection.msgtype
            assert int(topic["Count"]) == connection.msgcount, connection.topic
            assert topic["Serialization Format"] == "cdr"
        assert f"Messages:          {bag.message_count}\n" in out
        # rosbags counts the last nanosecond in (its end is the last message's time + 1).
        assert f"Duration:          {(bag.duration - 1) / 1e9:.9f}s\n" in out
        start, end = divmod(bag.start_time, 10**9), divmod(bag.end_time - 1, 10**9)
        assert f"({start[0]}.{start[1]:09d})" in out.split("Start:")[1].splitlines()[0]
        assert f"({end[0]}.{end[1]:09d})" in out.split("End:")[1].splitlines()[0]
    # Every FLS's publisher of its latched measurements, one QoS for all.
    measurements = said["/swarm/measurements"]["Offered QoS"]
    assert measurements == f"reliable, transient_local x{len(world.ids)}"
    assert said[RADIO[0]]["Offered QoS"] == "reliable, volatile x1"
    # The MCAP file alone says the same of its messages, from its own statistics.
    folder, alone = bag_info(path), bag_info(path / "run_0.mcap")
    assert (alone.start, alone.duration, alone.count) == (
        folder.start,
        folder.duration,
        folder.count,
    )
    assert {(t.name, t.type_name, t.count) for t in alone.topics} == {
        (t.name, t.type_name, t.count) for t in folder.topics
    }


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


@pytest.mark.parametrize(
    ("metadata", "message"),
    [
        ("rosbag2_bagfile_information: {storage_identifier: mcap, relative_file_paths: [a.mcap]}",
         "a.mcap: no such recording file"),
        ("hello: there", "not a rosbag2 bag (metadata.yaml lacks 'rosbag2_bagfile_information')"),
        # Its storage is there (a file by the name it gives), its topics are not.
        (
            "rosbag2_bagfile_information: "
            "{storage_identifier: mcap, relative_file_paths: [metadata.yaml]}",
            "not a rosbag2 bag (metadata.yaml lacks 'topics_with_message_count')",
        ),
        ("hello: [", "not valid YAML"),
    ],
)  # fmt: skip
def test_replay_info_of_a_folder_that_is_not_a_bag_says_so_in_one_line(
    tmp_path, metadata, message
):
    (tmp_path / "metadata.yaml").write_text(metadata + "\n")
    code, out, err = replay_info(tmp_path)
    assert code == 2 and out == "" and message in err, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    code, out, err = replay_info(tmp_path / "absent")
    assert code == 2 and "no such file" in err and len(err.strip().splitlines()) == 1


def test_replay_info_of_an_mcap_file_cut_short_counts_what_it_holds_and_says_where_it_ends(
    tmp_path,
):
    path = tmp_path / "run.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream, chunk_size=2048)  # many chunks: half the file is whole ones
        writer.start(profile="ros2", library="test")
        definition = message_definition("geometry_msgs/msg/Vector3").encode()
        schema = writer.register_schema("geometry_msgs/msg/Vector3", "ros2msg", definition)
        channels = [writer.register_channel(f"/swarm/{n}", "cdr", schema) for n in "ab"]
        for number in range(400):
            data = serialize_message(Vector3(x=float(number)))
            at = 10**18 + number * 1000
            writer.add_message(channels[number % 4 == 0], log_time=at, data=data, publish_time=at)
        writer.finish()
    whole = bag_info(path)
    assert whole.count == 400 and whole.cut is None
    assert {t.name: t.count for t in whole.topics} == {"/swarm/a": 300, "/swarm/b": 100}
    assert (whole.start, whole.end) == (10**18, 10**18 + 399 * 1000)
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    read = [message.topic for message in _readable(path)]
    cut = bag_info(path)
    assert 0 < cut.count == len(read) < 400 and "after message" in (cut.cut or "")
    assert {t.name: t.count for t in cut.topics} == {
        n: read.count(n) for n in ("/swarm/a", "/swarm/b")
    }
    code, out, err = replay_info(path)
    assert code == 0 and f"Messages:          {cut.count}\n" in out and "Cut short:" in out, err


def _readable(path):
    """The messages of a recording up to where it is cut."""
    read = []
    with contextlib.suppress(SwazureError):  # the cut: what came before it stays read
        for message in read_recording(path):
            read.append(message)
    return read


def test_replay_publishes_the_recording_again(recorded_run, domain, context):
    path, _, result, _ = recorded_run
    recorded = recorded_messages(path)
    probe = Probe(
        context,
        [
            *((topic, PathOffer, ROUND_QOS) for topic in RADIO),
            # Every message, not the newest per reader: the replay sends them in a burst.
            ("/swarm/measurements", Measurements, KEEP_ALL_LATCHED),
        ],
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe.node)
    # The radio's messages are volatile: the probe must have matched the replay's
    # publishers before the first one. Discovering a new participant was seen to take
    # 2.5 s on a loaded 2-core machine (BENCHMARKS.md, one FLS per process), and longer
    # with two suites side by side: 20 s of delay.
    replay = subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "replay", str(path),
         "--domain-id", str(domain), "--rate", "2", "--delay", "20"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        wait_until(
            lambda: replay.poll() is not None,
            PATIENCE,
            lambda: executor.spin_once(timeout_sec=0.05),
        )
        for _ in range(200):  # what is still queued here
            executor.spin_once(timeout_sec=0.01)
        _, err = replay.communicate(timeout=PATIENCE)
    finally:
        if replay.poll() is None:
            replay.kill()
        executor.shutdown()
        probe.node.destroy_node()
    assert replay.returncode == 0, err
    assert f"replayed {sum(len(v) for v in recorded.values())} messages" in err
    assert "every reliable reader acknowledged every message" in err, err
    replayed = joined(probe.received, RADIO)
    assert sorted(replayed) == sorted(joined(recorded, RADIO))
    assert len(replayed) == result.traffic.messages["radio"]
    assert sorted(probe.received["/swarm/measurements"]) == sorted(recorded["/swarm/measurements"])


@pytest.mark.parametrize(
    ("content", "message"),
    [(b"", "not an MCAP recording"), (b"hello, not a recording", "not an MCAP recording")],
)
def test_replay_of_a_file_that_is_not_a_recording_says_so_in_one_line(tmp_path, content, message):
    path = tmp_path / "run.mcap"
    path.write_bytes(content)
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "replay", str(path)],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert run.returncode == 2 and message in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1 and "Traceback" not in run.stderr


def test_a_recording_corrupted_in_the_middle_is_played_to_its_last_good_chunk(tmp_path, domain):
    path = tmp_path / "run.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream, chunk_size=2048)  # many chunks, each checked by its CRC
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(
            "geometry_msgs/msg/Vector3", "ros2msg", message_definition(
                "geometry_msgs/msg/Vector3").encode()
        )  # fmt: skip
        channel = writer.register_channel("/swarm/v", "cdr", schema)
        for number in range(400):
            data = serialize_message(Vector3(x=float(number)))
            writer.add_message(channel, log_time=number, data=data, publish_time=number)
        writer.finish()
    with path.open("rb") as stream:
        chunks = make_reader(stream).get_summary().chunk_indexes
    middle = chunks[len(chunks) // 2]  # damage the records of a chunk in the middle
    data = bytearray(path.read_bytes())
    at = middle.chunk_start_offset + middle.chunk_length // 2
    data[at : at + 32] = b"\x5a" * 32
    path.write_bytes(bytes(data))
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "replay", str(path), "--delay", "0.01",
         "--rate", "1000", "--domain-id", str(domain)],
        capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert run.returncode == 2 and "Traceback" not in run.stderr, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
    said = run.stderr.split("corrupted after message ")[1]
    played = int(said.split(" ")[0])
    assert 0 < played < 400 and f"replayed the {played} messages before it" in said, said


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
