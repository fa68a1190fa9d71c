"""Flat messages read from and written as their CDR bytes (``ros.plumbing.records``).

A packed process hears an offer from every FLS of the other processes each
round, and sends one from each of its own: read and written as bytes, with
the tag's content made in the same pass, they must be exactly the message
rclpy would make, and cover exactly what the tag of the message covers.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import deserialize_message
from swazure_interfaces.msg import MoveCommands, PathOffer

from swazure_ros.core.errors import MessageError
from swazure_ros.ros.convert.units import message_of
from swazure_ros.ros.plumbing.cdr import serialize
from swazure_ros.ros.plumbing.interfaces import message_class
from swazure_ros.ros.security.auth import AUTH_BYTES, SwarmKey, content, new_key
from swazure_ros.ros.security.records import record_parser, record_writer

from ...conftest import FUZZ, REPO
from ..fuzz import message

IDS = [0, 1, 2, 407]


def flat(type_name: str) -> bool:
    try:
        record_parser(message_class(type_name))
    except MessageError:
        return False
    return True


#: Every type of ours that records read: fields of primitives, strings and their arrays.
FLAT = [
    name
    for name in (f"swazure_interfaces/msg/{path.stem}" for path in sorted(
        (REPO / "msg_defs" / "msg").glob("*.msg")
    ))
    if flat(name)
]  # fmt: skip


def fields_of(sent) -> dict:
    """``sent``'s fields by dotted name, as a writer takes them (``auth`` left out)."""
    out = {}

    def walk(of, prefix):
        for name, text in of.get_fields_and_field_types().items():
            value = getattr(of, name)
            if "/" in text and not text.startswith("sequence<") and "[" not in text:
                walk(value, f"{prefix}{name}.")
            elif f"{prefix}{name}" != "auth":
                out[f"{prefix}{name}"] = value

    walk(sent, "")
    return out


def test_the_swarm_s_round_messages_are_all_read_as_records():
    for name in ("PathOffer", "PathWalk", "PoseEstimates", "RoundAck", "DiscoveryControl"):
        assert f"swazure_interfaces/msg/{name}" in FLAT
    # A sequence of messages has no record: MoveCommands is read as a message.
    with pytest.raises(MessageError, match="MoveCommands: no record of an array of 'swazure"):
        record_parser(MoveCommands)


@pytest.mark.parametrize("type_name", FLAT)
@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_a_record_holds_the_message_s_fields_and_what_its_tag_covers(type_name, data):
    kind = message_class(type_name)
    sent = data.draw(message(kind, IDS))
    record = record_parser(kind)(serialize(sent))
    assert record.content == content(sent)
    assert record.auth == bytes(sent.auth)
    back = deserialize_message(serialize(sent), kind)  # what rclpy reads of the same bytes
    for name, value in fields_of(back).items():
        got = record
        for part in name.split("."):
            got = getattr(got, part)
        if isinstance(value, str):
            assert got == value
        elif isinstance(value, bool | int | float):
            assert np.array_equal(np.array(got), np.array(value), equal_nan=True)
        else:  # an array: the same values, bit for bit
            assert np.asarray(got).tobytes() == np.asarray(value).tobytes()


@pytest.mark.parametrize("type_name", FLAT)
@settings(FUZZ, max_examples=40)
@given(data=st.data())
def test_a_written_record_is_the_serialised_message_and_signs_what_its_tag_covers(type_name, data):
    kind = message_class(type_name)
    sent = data.draw(message(kind, IDS))
    covered = []

    def auth(content_bytes: bytes) -> bytes:
        covered.append(content_bytes)
        return bytes(sent.auth)

    written = record_writer(kind)(fields_of(sent), auth)
    assert written == serialize(sent)
    assert covered == [content(sent)]
    # The message made of the same fields is the same message, less its tag.
    made = message_of(kind, fields_of(sent))
    made.auth = sent.auth
    assert serialize(made) == written


def test_a_written_offer_is_signed_with_the_swarm_s_key_and_its_record_verifies():
    key = SwarmKey(new_key())
    fields = {
        "header.frame_id": "fls_2", "run_id": 7, "phase": 1, "round": 3, "sender_id": 2,
        "source_ids": np.array([0, 1]), "hops": [1, 1], "lengths": [13.0, 12.5],
        "errors": [0.2, 0.2], "vectors": np.arange(6.0), "path_offsets": [0, 2, 4],
        "path_ids": [0, 2, 1, 2], "fit_label": -1,
    }  # fmt: skip
    data = record_writer(PathOffer)(fields, key.auth)
    offer = deserialize_message(data, PathOffer)
    assert key.verify(offer) is offer and len(offer.auth) == AUTH_BYTES
    record = record_parser(PathOffer)(data)
    key.verify_content(record.auth, record.content)
    assert record.path_ids.tolist() == [0, 2, 1, 2] and record.header.frame_id == "fls_2"
    # Another swarm's key refuses it, as it refuses the message.
    with pytest.raises(MessageError, match="not signed with this swarm's key"):
        SwarmKey(new_key()).verify_content(record.auth, record.content)


@pytest.mark.parametrize(
    ("data", "why"),
    [
        (b"\x00\x00\x00\x00" + bytes(40), "not a PathOffer in little-endian CDR"),
        (b"\x00\x01\x00\x00" + bytes(10), "CDR bytes end inside their PathOffer, or are not one"),
        (b"", "not a PathOffer in little-endian CDR"),
    ],
)
def test_bytes_that_are_no_little_endian_offer_are_refused_in_one_line(data, why):
    with pytest.raises(MessageError, match=why):
        record_parser(PathOffer)(data)


def test_an_array_longer_than_the_bytes_is_refused_not_read_past_the_end():
    data = bytearray(serialize(PathOffer(source_ids=[1, 2, 3])))
    # The source_ids' length, after the encapsulation (4), the header (stamp 8, frame_id's
    # length 4 and its NUL: 13) and run_id .. finished (16 to 34, aligned: 36): a million.
    at = 4 + 36
    assert int.from_bytes(data[at : at + 4], "little") == 3
    data[at : at + 4] = (10**6).to_bytes(4, "little")
    with pytest.raises(MessageError, match="CDR bytes end inside their PathOffer"):
        record_parser(PathOffer)(bytes(data))
