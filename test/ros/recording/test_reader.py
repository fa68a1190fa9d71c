"""Reading a recording back: what it holds, as ``ros2 bag info`` says it, also cut short."""

from __future__ import annotations

import contextlib
import subprocess
import sys

import pytest
from geometry_msgs.msg import Vector3
from mcap.writer import Writer
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader

from swazure_ros.core.errors import SwazureError
from swazure_ros.ros.recording.metadata import message_definition
from swazure_ros.ros.recording.reader import bag_info, read_recording

from ...waits import PATIENCE
from .conftest import RADIO


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
