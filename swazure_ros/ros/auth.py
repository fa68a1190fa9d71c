"""The swarm's key: every protocol message is signed, and a message without a good tag is dropped.

The Fast DDS of the PyPI wheels is built without DDS Security, so SROS2's
authenticated participants and signed submessages are not available here
(docs/security.md). What the swarm can do on the wheels is sign its own
messages: each protocol message type ends with ``uint8[] auth``, an
HMAC-SHA256 tag, under a 32-byte key every process of the swarm holds, of
every other field. A peer on the domain without the key can publish
whatever it likes: no process takes it.

The tag covers the fields' values, not the serialised bytes: CDR leaves its
alignment padding uninitialised, so one message serialises to different
bytes each time. :func:`feed` writes each field in order, with its type and
length, into the MAC.
"""

from __future__ import annotations

import array
import hashlib
import hmac
import struct
from typing import Any, TypeVar

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

from ..core.errors import MessageError, SwazureError
from .keys import KEY_BYTES, new_key, read_key

__all__ = ["SwarmKey", "feed", "new_key", "read_key"]

T = TypeVar("T")

#: The field that carries the tag.
AUTH_FIELD = "auth"


def feed(mac: Any, value: Any) -> None:
    """Write ``value`` (a message, or one of its fields' values) into ``mac``, unambiguously.

    Each value is written with a one-letter type and, for sequences, its
    length, so that two different messages never write the same bytes.
    """
    if hasattr(value, "get_fields_and_field_types"):
        fields = value.get_fields_and_field_types()
        mac.update(b"m" + len(fields).to_bytes(4, "little"))
        for name in fields:
            if name != AUTH_FIELD:
                feed(mac, getattr(value, name))
    elif isinstance(value, bool | int):
        mac.update(b"i" + int(value).to_bytes(9, "little", signed=True))
    elif isinstance(value, float):
        mac.update(b"f" + struct.pack("<d", value))
    elif isinstance(value, str):
        text = value.encode("utf-8", "surrogatepass")
        mac.update(b"s" + len(text).to_bytes(8, "little") + text)
    elif isinstance(value, array.array | np.ndarray | bytes):
        raw = memoryview(value).cast("B") if not isinstance(value, bytes) else value
        kind = value.typecode if isinstance(value, array.array) else getattr(value, "dtype", "B")
        mac.update(b"a" + str(kind).encode() + len(raw).to_bytes(8, "little"))
        mac.update(raw)
    elif isinstance(value, list | tuple):
        mac.update(b"l" + len(value).to_bytes(8, "little"))
        for item in value:
            feed(mac, item)
    else:
        raise TypeError(f"cannot sign a {type(value).__name__}")


class SwarmKey:
    """Signs what a process sends and checks what it hears; without a key, does neither."""

    def __init__(self, key: bytes | None = None) -> None:
        if key is not None and len(key) != KEY_BYTES:
            raise SwazureError(f"a swarm key is {KEY_BYTES} bytes, got {len(key)}")
        self._key = key

    def __repr__(self) -> str:
        return f"SwarmKey({'active' if self.active else 'none'})"  # never the key itself

    @property
    def active(self) -> bool:
        """True when messages are signed and checked."""
        return self._key is not None

    def tag(self, message: Any) -> bytes:
        """The tag of ``message``: HMAC-SHA256 of every field but ``auth``."""
        assert self._key is not None
        mac = hmac.new(self._key, digestmod=hashlib.sha256)
        feed(mac, message)
        return mac.digest()

    def sign(self, message: T) -> T:
        """``message`` with its ``auth`` set to its tag (left empty without a key)."""
        if self._key is not None:
            setattr(message, AUTH_FIELD, self.tag(message))
        return message

    def verify(self, message: T) -> T:
        """``message`` if the swarm's key signed it (or there is no key); MessageError if not."""
        if self._key is not None and not hmac.compare_digest(
            bytes(getattr(message, AUTH_FIELD)), self.tag(message)
        ):
            raise MessageError("not signed with the swarm's key")
        return message

    def serialize(self, message: Any) -> bytes:
        """``message`` signed and serialised."""
        return bytes(serialize_message(self.sign(message)))

    def deserialize(self, data: bytes, kind: type[T]) -> T:
        """The message of type ``kind`` in ``data``; MessageError if not one, or not signed."""
        try:
            message = deserialize_message(data, kind)
        except Exception as err:  # rclpy reports undecodable bytes with bare exceptions
            raise MessageError(f"not a {kind.__name__}") from err
        return self.verify(message)
