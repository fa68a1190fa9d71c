"""The swarm's key: every protocol message is signed, and a message without a good tag is dropped.

The Fast DDS of the PyPI wheels is built without DDS Security, so SROS2's
authenticated participants and signed submessages are not available here
(docs/security.md). What the swarm can do on the wheels is sign its own
messages: each protocol message type ends with ``uint8[] auth``, an
HMAC-SHA256 tag, under a 32-byte key every process of the swarm holds, of
every other field. A peer on the domain without the key can publish
whatever it likes: no process takes it.

The tag covers the fields' values, not the serialised bytes: CDR says
nothing of what its alignment padding holds (rclpy's serialize_message leaves
heap bytes there; the swarm's senders zero them, :mod:`..plumbing.cdr`), so
one message may come as different bytes from different writers.
:func:`content` writes each field in order, with its type and length, into
the MAC.

A tag is bound to one life of the swarm: the MAC also covers the swarm
instance, 16 random bytes made when the swarm starts and never sent, so a
message recorded from an earlier swarm started with the same key file fails
the check. And it is bound to its place in its sender's stream: ``auth`` is
the sender's random id and a counter (nanoseconds of the wall clock, made
strictly increasing) before the MAC, and each receiver keeps a
:class:`Freshness` that refuses a counter it took before or one older than
its window.
"""

from __future__ import annotations

import functools
import hashlib
import hmac
import operator
import secrets
import struct
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar, cast

from rclpy.serialization import deserialize_message

from ...core.errors import MessageError, SwazureError
from ..plumbing.cdr import serialize
from ..plumbing.interfaces import message_class
from .keys import KEY_BYTES, new_key, read_key

__all__ = ["Freshness", "SwarmKey", "content", "new_key", "read_key"]

T = TypeVar("T")

#: Messages whose bytes a key remembers as checked (a round of the largest shape).
CHECKED_KEPT = 8192
#: Messages a key hands out again, the very object, when their bytes come back soon:
#: the radio and the coordinator of one process both hear every offer, one just after
#: the other. Receivers read what they are handed and never change it.
SHARED_KEPT = 64
#: The field that carries the tag.
AUTH_FIELD = "auth"
#: Bytes of a swarm instance's id, made at random when the swarm starts.
INSTANCE_BYTES = 16
#: The instance an announcement of the instance is signed under: a constant, known to all.
ANNOUNCEMENT = b"swazure:instance"
#: ``auth``: the sender's id (8 random bytes a process), its counter, then the MAC.
_HEADER = struct.Struct("<8sQ")
#: Bytes of the MAC (HMAC-SHA256), and of the whole ``auth`` field.
MAC_BYTES = 32
AUTH_BYTES = _HEADER.size + MAC_BYTES
#: How far behind its sender's newest, in the counter's nanoseconds, a message may still
#: arrive: DDS keeps order per writer only, and one process has several writers a topic.
REORDER_WINDOW_NS = 10_000_000_000
#: Senders a receiver keeps the counters of; the one heard from least recently goes first.
SENDERS_KEPT = 4096


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


def content_of(kind: Any, scalars: Sequence[Any], others: Sequence[bytes]) -> bytes:
    """:func:`content` of a message of type ``kind`` read as bytes, not as an object.

    Parameters
    ----------
    kind : type
        A message type without sequences of strings or of messages.
    scalars : sequence
        Its primitives, nested messages' inline, in the order of its fields.
    others : sequence of bytes-like
        Its strings (to their first NUL, UTF-8) and arrays of primitives (their
        bytes, little-endian), in the order of its fields, ``auth`` left out:
        each after its length in bytes, as 8 little-endian bytes of its own.

    Returns
    -------
    bytes
        What :func:`content` writes of the same message.
    """
    plan = _plan(kind)
    if any(code in "ml" for _, code in plan.others) or len(others) != 2 * len(plan.others):
        raise MessageError(f"{kind.__name__}: not one string or array a field")
    return b"".join([plan.scalars.pack(*scalars), *others])


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
    """Signs what a process sends and checks what it hears; without a key, does neither.

    ``instance``: the swarm instance's id (INSTANCE_BYTES), inside every tag;
    None makes a fresh one, for the process that starts a swarm. Each
    SwarmKey is a sender of its own (a random id and its counter): a
    process makes its own, never a copy of another's.
    """

    def __init__(self, key: bytes | None = None, instance: bytes | None = None) -> None:
        if key is not None and len(key) != KEY_BYTES:
            raise SwazureError(f"a swarm key is {KEY_BYTES} bytes, got {len(key)}")
        if instance is None:
            instance = secrets.token_bytes(INSTANCE_BYTES)
        if len(instance) != INSTANCE_BYTES:
            raise SwazureError(f"a swarm instance is {INSTANCE_BYTES} bytes, got {len(instance)}")
        self._key = key
        self.instance = instance
        self.sender = secrets.token_bytes(_HEADER.size - 8)
        self._counter = 0
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

    @property
    def material(self) -> tuple[bytes | None, bytes]:
        """(key, instance): what another process of this swarm makes its own SwarmKey of."""
        return self._key, self.instance

    def for_instance(self, instance: bytes) -> SwarmKey:
        """A SwarmKey of the same key for ``instance`` (a sender of its own)."""
        return SwarmKey(self._key, instance)

    def tag(self, message: Any, header: bytes) -> bytes:
        """HMAC-SHA256 of the instance, ``header`` (sender, counter) and :func:`content`."""
        return self._mac(header, content(message))

    def sign(self, message: T) -> T:
        """``message`` with ``auth`` set: sender, next counter, tag (empty without a key)."""
        if self._key is not None:
            setattr(message, AUTH_FIELD, self.auth(content(message)))
        return message

    def auth(self, covered: bytes) -> bytes:
        """The ``auth`` field of a message whose :func:`content` is ``covered``: sender, next
        counter, tag; empty without a key (for messages written as bytes)."""
        if self._key is None:
            return b""
        # Wall-clock nanoseconds, so that a receiver's window is a span of time.
        self._counter = max(self._counter + 1, time.time_ns())
        header = _HEADER.pack(self.sender, self._counter)
        return header + self._mac(header, covered)

    def _mac(self, header: bytes, covered: bytes) -> bytes:
        assert self._key is not None
        return hmac.digest(self._key, self.instance + header + covered, "sha256")

    def verify(self, message: T) -> T:
        """``message`` if this swarm signed it (or there is no key); MessageError if not."""
        if self._key is None:
            return message
        self.verify_content(bytes(getattr(message, AUTH_FIELD)), content(message))
        return message

    def verify_content(self, auth: bytes, covered: bytes) -> None:
        """MessageError unless ``auth`` is this swarm's tag of a message whose :func:`content`
        is ``covered`` (for messages read as bytes); nothing to check without a key."""
        if self._key is None:
            return
        header = auth[: _HEADER.size]
        if len(auth) != AUTH_BYTES or not hmac.compare_digest(
            auth[_HEADER.size :], self._mac(header, covered)
        ):
            raise MessageError("not signed with this swarm's key and instance")

    def serialize(self, message: Any) -> bytes:
        """``message`` signed and serialised: its CDR bytes exactly (:func:`.cdr.serialize`)."""
        return serialize(self.sign(message))

    def deserialize(self, data: bytes, kind: type[T]) -> T:
        """The message of type ``kind`` in ``data``; MessageError if not one, or not signed.

        Bytes checked once are not checked again: in a process that hosts
        the radio and the coordinator, both hear every offer. When the same
        bytes come back soon after, the message read then is handed out
        again (``SHARED_KEPT``), so a second receiver does not read it again.
        """
        if self._key is None or not hasattr(kind, "auth"):
            # A type without a tag (a camera driver's image) is not the swarm's to sign:
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


def signed_at(message: Any) -> int:
    """The counter of ``message``'s ``auth``: wall-clock ns when signed; 0 if unsigned."""
    auth = bytes(getattr(message, AUTH_FIELD, b""))
    return int(_HEADER.unpack_from(auth)[1]) if len(auth) == AUTH_BYTES else 0


class Freshness:
    """What one receiver took from each sender: a message taken before, or too old, is refused.

    A counter more than ``window`` below its sender's newest is refused, and
    so is one already taken; within the window, messages may come in any
    order (DDS keeps order per writer only). Without a key, nothing is refused.
    """

    def __init__(self, window: int = REORDER_WINDOW_NS, senders: int = SENDERS_KEPT) -> None:
        self.window = window
        self._senders = senders
        # sender -> (newest counter, counters taken within the window, in arrival order)
        self._taken: dict[bytes, tuple[list[int], set[int], deque[int]]] = {}

    def take(self, message: Any) -> None:
        """Take ``message``'s counter; MessageError if taken before or older than the window."""
        auth = bytes(getattr(message, AUTH_FIELD, b""))
        if len(auth) != AUTH_BYTES:
            return  # a keyless swarm's message: nothing to order it by
        sender, counter = _HEADER.unpack_from(auth)
        state = self._taken.pop(sender, None)
        if state is None:
            state = ([counter], set(), deque())
            if len(self._taken) >= self._senders:
                del self._taken[next(iter(self._taken))]
        self._taken[sender] = state  # the most recently heard last
        newest, seen, order = state
        if counter <= newest[0] - self.window:
            raise MessageError("older than its sender's window: a replay")
        if counter in seen:
            raise MessageError("taken before: a replay")
        seen.add(counter)
        order.append(counter)
        if counter > newest[0]:
            newest[0] = counter
            floor = counter - self.window
            while order and order[0] <= floor:
                seen.discard(order.popleft())


def _deserialize(data: bytes, kind: type[T]) -> T:
    """The message of type ``kind`` in ``data``; MessageError if the bytes are not one."""
    try:
        message: T = deserialize_message(data, kind)
    except Exception as err:  # rclpy reports undecodable bytes with bare exceptions
        raise MessageError(f"not a {kind.__name__}") from err
    return message
