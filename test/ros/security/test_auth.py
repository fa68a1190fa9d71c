"""The swarm's key: a tag covers every field, and only the key's holder makes a good one."""

from __future__ import annotations

import os
import stat

import pytest
from geometry_msgs.msg import Vector3
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message, serialize_message
from swazure_interfaces.msg import MoveCommand, MoveCommands, PathOffer, PoseEstimates

from swazure_ros.core.errors import MessageError, SwazureError
from swazure_ros.ros.security.auth import Freshness, SwarmKey, content, new_key
from swazure_ros.ros.security.keys import read_key, write_key

from ...conftest import FUZZ
from ..fuzz import message

KEY = SwarmKey(new_key())
IDS = [0, 1, 2, 407]


def offer() -> PathOffer:
    return PathOffer(
        run_id=7, phase=1, round=3, sender_id=2, source_ids=[0], hops=[2], lengths=[13.0],
        errors=[0.2], vectors=[1.0, 2.0, 3.0], path_offsets=[0, 3], path_ids=[0, 1, 2],
    )  # fmt: skip


def test_a_signed_message_is_taken_after_the_wire_and_its_auth_is_sender_counter_and_tag():
    data = KEY.serialize(offer())
    back = KEY.deserialize(data, PathOffer)
    assert len(back.auth) == 8 + 8 + 32 and list(back.path_ids) == [0, 1, 2]
    assert bytes(back.auth[:8]) == KEY.sender


def test_a_message_of_another_instance_of_the_swarm_is_refused():
    """Same key file, a later start: what the earlier swarm signed fails the tag."""
    secret = new_key()
    earlier, later = SwarmKey(secret), SwarmKey(secret)
    assert earlier.instance != later.instance
    with pytest.raises(MessageError, match="not signed with this swarm's key and instance"):
        later.deserialize(earlier.serialize(offer()), PathOffer)
    # Another process of the later swarm: same key and instance, a sender of its own.
    peer = later.for_instance(later.instance)
    assert peer.sender != later.sender
    assert peer.deserialize(later.serialize(offer()), PathOffer).run_id == 7


def test_counters_of_one_sender_increase_and_a_receiver_refuses_a_replay_or_a_stale_one():
    signed = [deserialize_message(KEY.serialize(offer()), PathOffer) for _ in range(4)]
    counters = [int.from_bytes(bytes(one.auth[8:16]), "little") for one in signed]
    assert counters == sorted(set(counters))
    freshness = Freshness(window=10**12)  # 1,000 s
    # Out of order within the window: taken.
    for one in (signed[1], signed[0], signed[3]):
        freshness.take(one)
    with pytest.raises(MessageError, match="taken before: a replay"):
        freshness.take(signed[1])
    old = deserialize_message(KEY.serialize(offer()), PathOffer)
    auth = bytes(old.auth)
    old.auth = auth[:8] + (counters[3] - 10**12).to_bytes(8, "little") + auth[16:]
    with pytest.raises(MessageError, match="older than its sender's window"):
        freshness.take(old)
    freshness.take(signed[2])  # still within the window of the newest
    # Each sender has its own counters; a keyless message is not ordered.
    freshness.take(deserialize_message(SwarmKey(new_key()).serialize(offer()), PathOffer))
    freshness.take(offer())
    freshness.take(offer())


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("run_id", 8),
        ("round", 4),
        ("sender_id", 1),
        ("pending", True),
        ("vectors", [1.0, 2.0, 3.5]),
        ("path_ids", [0, 2, 2]),
        ("lengths", [13.000001]),
    ],
)
def test_a_changed_field_breaks_the_tag(field, value):
    signed = deserialize_message(KEY.serialize(offer()), PathOffer)
    setattr(signed, field, value)
    with pytest.raises(MessageError, match="not signed with this swarm's key"):
        KEY.verify(signed)
    assert KEY.verify(deserialize_message(KEY.serialize(offer()), PathOffer)).run_id == 7


def test_another_key_and_no_key_are_refused_and_a_keyless_swarm_takes_anything():
    theirs = SwarmKey(new_key())
    for data in (theirs.serialize(offer()), SwarmKey().serialize(offer())):
        with pytest.raises(MessageError):
            KEY.deserialize(data, PathOffer)
        assert SwarmKey().deserialize(data, PathOffer).run_id == 7


def test_garbage_bytes_are_one_message_error():
    with pytest.raises(MessageError, match="not a PathOffer"):
        KEY.deserialize(b"\x00\x01\x00\x00garbage", PathOffer)


@pytest.mark.parametrize("kind", [PoseEstimates, MoveCommands])
@settings(FUZZ, max_examples=200)
@given(data=st.data())
def test_content_differs_whenever_the_messages_do(kind, data):
    """Two messages write the same content exactly when every field but auth is equal.

    PoseEstimates is arrays; MoveCommands nests messages in a sequence.
    """
    first, second = data.draw(message(kind, IDS)), data.draw(message(kind, IDS))
    first.auth, second.auth = [], []
    # What crosses the wire is what the tag covers (a string ends at its first NUL).
    first = deserialize_message(serialize_message(first), kind)
    second = deserialize_message(serialize_message(second), kind)
    assert content(first) == content(deserialize_message(serialize_message(first), kind))
    # repr tells NaN from NaN and -0.0 from 0.0 as the bits do.
    assert (content(first) == content(second)) == (repr(first) == repr(second))


def test_nested_messages_are_covered():
    moves = MoveCommands(commands=[MoveCommand(fls_id=2, displacement=Vector3(x=1.0))])
    signed = deserialize_message(KEY.serialize(moves), MoveCommands)
    signed.commands[0].displacement.x = 123.0
    with pytest.raises(MessageError):
        KEY.verify(signed)


def test_a_key_file_is_private_and_reads_back(tmp_path):
    path = tmp_path / "swarm.key"
    key = new_key()
    write_key(path, key)
    assert read_key(path) == key
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600
    (tmp_path / "short.key").write_text("abcd\n")
    with pytest.raises(SwazureError, match="64 hexadecimal digits"):
        read_key(tmp_path / "short.key")


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o604, 0o660, 0o620, 0o777], ids=oct)
def test_a_key_file_others_may_read_or_write_is_taken_with_one_line_of_warning(
    tmp_path, capsys, mode
):
    # Issue 66: a key file readable by others was taken without a word.
    path = tmp_path / "swarm.key"
    key = new_key()
    write_key(path, key)
    assert read_key(path) == key
    assert capsys.readouterr().err == ""  # its owner's alone: not a word
    os.chmod(path, mode)
    assert read_key(path) == key
    said = capsys.readouterr().err
    assert said.count("\n") == 1, said
    assert said.startswith(f"warning: swarm key file {path} is open to others than its owner")
    assert f"(mode {mode:04o})" in said and f"chmod 600 {path}" in said


@pytest.mark.parametrize("special", ["fifo", "/dev/zero", "folder"])
def test_a_key_file_that_is_not_a_small_regular_file_is_refused_in_one_line(tmp_path, special):
    if special == "fifo":
        path = tmp_path / "swarm.key"
        os.mkfifo(path)  # reading it would block for ever
    elif special == "folder":
        path = tmp_path
    else:
        path = special  # reading it whole would fill memory
    with pytest.raises(SwazureError, match="expected a swarm key file") as refused:
        read_key(path)
    assert "\n" not in str(refused.value)
