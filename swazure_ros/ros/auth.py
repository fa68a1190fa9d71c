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
bytes each time. :func:`content` writes each field in order, with its type and
length, into the MAC.
"""

from __future__ import annotations

import array
import functools
import hmac
import struct
from typing import Any, TypeVar

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

from ..core.errors import MessageError, SwazureError
from .keys import KEY_BYTES, new_key, read_key

__all__ = ["SwarmKey", "content", "new_key", "read_key"]

T = TypeVar("T")

#: The field that carries the tag.
AUTH_FIELD = "auth"


@functools.cache
def _fields(kind: type) -> tuple[str, ...]:
    """The fields of message type ``kind`` that the tag covers, in order."""
    return tuple(name for name in kind.get_fields_and_field_types() if name != AUTH_FIELD)


_DOUBLE = struct.Struct("<d").pack


def content(message: Any) -> bytes:
    """Every field of ``message`` but ``auth``, written unambiguously: what the tag covers.

    Each value is written with a one-letter type and, for sequences, its
    length, so that two different messages never write the same bytes.
    """
    parts: list[bytes] = []
    _write(parts, message)
    return b"".join(parts)


def _write(parts: list[bytes], value: Any) -> None:
    kind = type(value)
    if kind is float:
        parts.append(b"f" + _DOUBLE(value))
    elif kind is bool:
        parts.append(b"T" if value else b"F")
    elif kind is int:
        parts.append(b"i" + value.to_bytes(9, "little", signed=True))
    elif kind is str:
        text = value.encode("utf-8", "surrogatepass")
        parts.append(b"s" + len(text).to_bytes(8, "little") + text)
    elif kind is array.array or kind is np.ndarray or kind is bytes:
        raw = bytes(memoryview(value).cast("B"))
        code = value.typecode if kind is array.array else str(getattr(value, "dtype", "B"))
        parts.append(b"a" + code.encode() + len(raw).to_bytes(8, "little") + raw)
    elif kind is list or kind is tuple:
        parts.append(b"l" + len(value).to_bytes(8, "little"))
        for item in value:
            _write(parts, item)
    elif hasattr(kind, "get_fields_and_field_types"):
        parts.append(b"m")
        for name in _fields(kind):
            _write(parts, getattr(value, name))
    else:
        raise TypeError(f"cannot sign a {kind.__name__}")


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
        """The tag of ``message``: HMAC-SHA256 of every field but ``auth`` (:func:`content`)."""
        assert self._key is not None
        return hmac.digest(self._key, content(message), "sha256")

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
