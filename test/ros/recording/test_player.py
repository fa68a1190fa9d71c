"""Playing a recording back: what was sent is what is published again, to its last good chunk."""

from __future__ import annotations

import subprocess
import sys

import pytest
from geometry_msgs.msg import Vector3
from mcap.reader import make_reader
from mcap.writer import Writer
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from swazure_interfaces.msg import Measurements, PathOffer

from swazure_ros.ros.plumbing.names import ROUND_QOS
from swazure_ros.ros.recording.metadata import message_definition

from ...waits import PATIENCE, wait_until
from ..helpers import joined
from .conftest import RADIO, Probe, recorded_messages

KEEP_ALL_LATCHED = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


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
