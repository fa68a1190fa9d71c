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

import functools
import hashlib
import hmac
import operator
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar, cast

from rclpy.serialization import deserialize_message, serialize_message

from ..core.errors import MessageError, SwazureError
from .interfaces import message_class
from .keys import KEY_BYTES, new_key, read_key

__all__ = ["SwarmKey", "content", "new_key", "read_key"]

T = TypeVar("T")

#: Messages whose bytes a key remembers as checked (a round of the largest shape).
CHECKED_KEPT = 8192
#: Messages a key hands out again, the very object, when their bytes come back soon:
#: the radio and the coordinator of one process both hear every offer, one just after
#: the other. Receivers read what they are handed and never change it.
SHARED_KEPT = 64
#: The field that carries the tag.
AUTH_FIELD = "auth"


#: struct codes of the fixed-size primitive field types (floats as doubles: exact).
_PRIMITIVES = {
    "boolean": "?", "octet": "B", "char": "B", "byte": "B", "uint8": "B", "int8": "b",
    "uint16": "H", "int16": "h", "uint32": "I", "int32": "i", "uint64": "Q", "int64": "q",
    "float": "d", "double": "d",
}  # fmt: skip


@dataclass(frozen=True)
class _Plan:
    """How to write one message type: its primitives in one struct, then the rest in order."""

    scalars: struct.Struct
    scalar_values: Callable[[Any], tuple[Any, ...]]  # every primitive, in one call
    others: tuple[tuple[Callable[[Any], Any], str], ...]  # (getter, "s" | "a" | "m" | "l")


@functools.cache
def _plan(kind: Any) -> _Plan:
    """The :class:`_Plan` of message type ``kind``: nested messages flattened, auth left out."""
    codes: list[str] = []
    scalars: list[str] = []
    others: list[tuple[Callable[[Any], Any], str]] = []

    def walk(kind: Any, prefix: str) -> None:
        for name, field in kind.get_fields_and_field_types().items():
            if not prefix and name == AUTH_FIELD:
                continue
            path = f"{prefix}{name}"
            if field in _PRIMITIVES:
                codes.append(_PRIMITIVES[field])
                scalars.append(path)
            elif field.startswith("string") or field.startswith("wstring"):
                others.append((operator.attrgetter(path), "s"))
            elif field.startswith("sequence<") or "[" in field:
                inner = field.partition("<")[2].rstrip(">").split(",")[0] or field.split("[")[0]
                code = "a" if inner in _PRIMITIVES else ("m" if "/" in inner else "l")
                others.append((operator.attrgetter(path), code))
            else:  # a nested message: its fields, flattened
                walk(message_class(field), f"{path}.")

    walk(kind, "")
    # attrgetter of several names gives their tuple in one call; of one, the value itself.
    values: Callable[[Any], tuple[Any, ...]]
    if len(scalars) > 1:
        values = operator.attrgetter(*scalars)
    elif scalars:
        one = operator.attrgetter(scalars[0])
        values = lambda message: (one(message),)  # noqa: E731
    else:
        values = lambda message: ()  # noqa: E731
    return _Plan(struct.Struct("<" + "".join(codes)), values, tuple(others))


def content(message: Any) -> bytes:
    """Every field of ``message`` but ``auth``, written unambiguously: what the tag covers.

    Primitives go in one struct of the type's fixed layout; each string,
    array and sequence goes with its length, so that two different messages
    never write the same bytes.
    """
    parts: list[bytes] = []
    _write(parts, message)
    return b"".join(parts)


def _write(parts: list[bytes], message: Any) -> None:
    plan = _plan(message.__class__)
    parts.append(plan.scalars.pack(*plan.scalar_values(message)))
    for get, code in plan.others:
        value = get(message)
        if code == "s":
            # The wire ends a string at its first NUL: so does the tag.
            text = value.partition("\0")[0].encode("utf-8", "surrogatepass")
            parts.append(len(text).to_bytes(8, "little") + text)
        elif code == "a":
            raw = value.tobytes() if hasattr(value, "tobytes") else bytes(value)
            parts.append(len(raw).to_bytes(8, "little") + raw)
        elif code == "m":
            parts.append(len(value).to_bytes(8, "little"))
            for item in value:
                _write(parts, item)
        else:  # a sequence of strings
            parts.append(len(value).to_bytes(8, "little"))
            for item in value:
                text = item.partition("\0")[0].encode("utf-8", "surrogatepass")
                parts.append(len(text).to_bytes(8, "little") + text)


class SwarmKey:
    """Signs what a process sends and checks what it hears; without a key, does neither."""

    def __init__(self, key: bytes | None = None) -> None:
        if key is not None and len(key) != KEY_BYTES:
            raise SwazureError(f"a swarm key is {KEY_BYTES} bytes, got {len(key)}")
        self._key = key
        # Digests of the bytes of messages whose tag was good, oldest first.
        self._checked: dict[bytes, None] = {}
        # The newest messages checked, by their bytes' digest and type.
        self._shared: dict[tuple[bytes, type], Any] = {}

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
        """The message of type ``kind`` in ``data``; MessageError if not one, or not signed.

        Bytes checked once are not checked again: in a process that hosts
        the radio and the coordinator, both hear every offer. When the same
        bytes come back soon after, the message read then is handed out
        again (``SHARED_KEPT``), so a second receiver does not read it again.
        """
        if self._key is None or not hasattr(kind, "auth"):
            # A type without a tag (a camera's Detections) is not the swarm's to sign:
            # what it says is checked for what it is (ros.convert).
            return _deserialize(data, kind)
        digest = hashlib.blake2b(data, digest_size=16).digest()
        shared = self._shared.get((digest, kind))
        if shared is not None:
            return cast(T, shared)
        message = _deserialize(data, kind)
        if digest not in self._checked:
            self.verify(message)
            self._checked[digest] = None
            if len(self._checked) > CHECKED_KEPT:
                del self._checked[next(iter(self._checked))]
        self._shared[(digest, kind)] = message
        if len(self._shared) > SHARED_KEPT:
            del self._shared[next(iter(self._shared))]
        return message


def _deserialize(data: bytes, kind: type[T]) -> T:
    """The message of type ``kind`` in ``data``; MessageError if the bytes are not one."""
    try:
        message: T = deserialize_message(data, kind)
    except Exception as err:  # rclpy reports undecodable bytes with bare exceptions
        raise MessageError(f"not a {kind.__name__}") from err
    return message
