"""The network boundary: every message and request from the ROS domain is checked where it arrives.

Anyone on the swarm's ROS domain can publish on its topics (docs/security.md).
So every callback that takes a message runs inside a :class:`Guard`: the
conversion in :mod:`.convert` checks the message (ids in the swarm, codes
known, arrays of matching lengths and bounded sizes, finite numbers) and
raises :class:`MessageError`; the guard drops the message, counts it by topic and
reason, and warns at most once every few seconds. An exception of any other
kind is a defect of ours: it is counted as ``internal`` and logged with its
type, and it never reaches the executor, so one message cannot stop a process
that hosts hundreds of FLSs. The counts are published on ``/diagnostics``
(diagnostic_msgs/DiagnosticArray) by the process's host node.
"""

from __future__ import annotations

import math
import re
import time
from collections import Counter
from collections.abc import Callable, Sized
from dataclasses import dataclass
from typing import Any, Protocol, TypeVar

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from numpy.typing import ArrayLike
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.subscription import Subscription

from ...core.arrays import FloatArray, IntArray
from ...core.errors import MessageError
from ...core.lookup import sorted_rows
from .auth import AUTH_BYTES, SENDERS_KEPT, Freshness, SwarmKey

#: Seconds between a guard's reports on /diagnostics (sent only when its counts changed).
DIAGNOSTICS_PERIOD = 1.0
#: Seconds between two warnings about dropped messages of one topic.
WARN_EVERY = 5.0
#: The counter of exceptions that were not a check's rejection (a defect of ours).
INTERNAL = "internal"

T = TypeVar("T")


class Signed(Protocol):
    """A message read as bytes: its ``auth`` field and what the tag covers."""

    @property
    def auth(self) -> bytes: ...

    @property
    def content(self) -> bytes: ...


R = TypeVar("R", bound=Signed)
_NUMBERS = re.compile(r"[-+]?\d[\d.e+-]*")


def check(condition: bool, reason: str) -> None:
    """Raise :class:`MessageError` with ``reason`` unless ``condition`` holds."""
    if not condition:
        raise MessageError(reason)


def check_ids(ids: ArrayLike, swarm: IntArray, what: str) -> IntArray:
    """``ids`` as int64 if every one is an FLS of ``swarm`` (sorted ids); MessageError if not."""
    wanted = np.asarray(ids, dtype=np.int64).reshape(-1)
    unknown = ~sorted_rows(swarm, wanted)[1]
    if unknown.any():
        raise MessageError(f"{what}: no FLS {int(wanted[unknown][0])} in this swarm")
    return wanted


def check_size(values: Sized, limit: int, what: str) -> None:
    """``values`` holds at most ``limit`` entries."""
    check(len(values) <= limit, f"{what}: {len(values)} entries, more than {limit}")


def check_finite(values: ArrayLike, what: str, allow_nan: bool = False) -> FloatArray:
    """``values`` as float64 if every one is finite (or NaN, if allowed); MessageError if not."""
    array = np.asarray(values, dtype=np.float64)
    bad = np.isinf(array) if allow_nan else ~np.isfinite(array)
    check(not bad.any(), f"{what}: not a finite number")
    return array


@dataclass(frozen=True)
class RateLimit:
    """At most ``per_second`` messages a second from one sender, ``burst`` at once.

    A sender is what the swarm's key proves; without a key, the whole topic
    (:class:`Buckets`).
    """

    per_second: float
    burst: float


class Buckets:
    """A token bucket per sender: its id in ``auth`` when ``keyed``, else one for everyone.

    ``keyed``: the messages were checked under the swarm's key, so the sender
    id in their ``auth`` is a swarm process's. Without a key, ``auth`` is
    whatever a peer wrote there (a made-up id a message would get a bucket of
    its own each), and rclpy 7.1 tells a subscriber nothing of a message's
    writer (its MessageInfo has timestamps and sequence numbers, no publisher
    GID): every sender of the topic shares one bucket.
    """

    def __init__(self, limit: RateLimit, keyed: bool, senders: int = SENDERS_KEPT) -> None:
        self.limit = limit
        self.keyed = keyed
        self._senders = senders
        self._tokens: dict[bytes, tuple[float, float]] = {}  # sender -> (tokens, at s)

    def allow(self, message: Any, now: float) -> bool:
        """Whether ``message``'s sender may cause work now (and take a token if so)."""
        auth = bytes(getattr(message, "auth", b"")) if self.keyed else b""
        sender = auth[:8] if len(auth) == AUTH_BYTES else b""
        tokens, at = self._tokens.pop(sender, (self.limit.burst, now))
        if len(self._tokens) >= self._senders:
            del self._tokens[next(iter(self._tokens))]
        tokens = min(self.limit.burst, tokens + (now - at) * self.limit.per_second)
        allowed = tokens >= 1.0
        self._tokens[sender] = (tokens - 1.0 if allowed else tokens, now)
        return allowed


class Guard:
    """Counts and reports the messages a process drops; wraps its callbacks.

    One guard per process (its host node), shared by every node there, so
    that the counts are the process's.
    """

    def __init__(self, node: Node, key: SwarmKey | None = None) -> None:
        self._node = node
        self.key = key or SwarmKey()
        self.dropped: Counter[tuple[str, str]] = Counter()  # (topic, reason) -> messages
        self.accepted: Counter[str] = Counter()  # topic -> messages taken
        # topic -> bytes of the messages its subscriptions took in, echoes left out: what
        # a process hears, as the bench's per-FLS traffic reads it (dropped ones too).
        self.heard_bytes: Counter[str] = Counter()
        self._warned_at: dict[str, float] = {}
        self._reported = -1
        self._diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        node.create_timer(DIAGNOSTICS_PERIOD, self.publish)

    @property
    def total_dropped(self) -> int:
        """Messages dropped, every topic and reason."""
        return sum(self.dropped.values())

    def wrap(self, topic: str, callback: Callable[[T], Any]) -> Callable[[T], None]:
        """``callback`` for messages of ``topic``, guarded: nothing it raises escapes."""

        def guarded(message: T) -> None:
            self.call(topic, callback, message)

        return guarded

    def subscribe(
        self,
        kind: type[T],
        topic: str,
        callback: Callable[[T], Any],
        qos: QoSProfile,
        node: Node | None = None,
        echoes: Callable[[bytes], bool] | None = None,
        rate: RateLimit | None = None,
        read: Callable[[bytes], T] | None = None,
    ) -> Subscription:
        """Subscribe ``node`` (the guard's own by default) to ``topic``, guarded and key-checked.

        The callback gets each message of type ``kind`` that the swarm's key
        signs; every other is dropped and counted. ``echoes(data)``: the
        process's own message come back, passed over uncounted. ``rate``: a
        sender's messages beyond it are dropped and counted, before any work
        (without a key, the topic's: :class:`Buckets`). ``read``: what makes the
        callback's argument of the bytes, checked (:meth:`record_reader`); the
        message of type ``kind`` by default (:meth:`reader`).
        """
        if read is None:
            read = self.reader(kind)
        buckets = Buckets(rate, keyed=self.key.active) if rate is not None else None

        def limited(message: T) -> T:
            if buckets is not None and not buckets.allow(message, time.monotonic()):
                who = "one sender" if buckets.keyed else "all senders, unsigned"
                raise MessageError(
                    f"over {buckets.limit.per_second:g} a second from {who} (rate limit)"
                )
            return message

        def take(data: bytes) -> None:
            if echoes is not None and echoes(data):
                return
            self.heard_bytes[topic] += len(data)
            self.call(topic, lambda: callback(limited(read(data))))

        return (node or self._node).create_subscription(kind, topic, take, qos, raw=True)

    def reader(self, kind: type[T]) -> Callable[[bytes], T]:
        """A function of one subscription's bytes: the message, if signed and fresh.

        Each subscription has its own :class:`Freshness`: DDS hands it each
        message once, so a counter it took before is a replay.
        """
        freshness = Freshness()

        def read(data: bytes) -> T:
            message = self.key.deserialize(data, kind)
            if self.key.active:
                freshness.take(message)
            return message

        return read

    def record_reader(self, parse: Callable[[bytes], R]) -> Callable[[bytes], R]:
        """A function of one subscription's bytes: ``parse(data)``, if signed and fresh.

        For a message read as bytes: ``parse`` gives a record with the
        message's ``auth`` and the ``content`` its tag covers (MessageError
        when the bytes are not one).
        """
        freshness = Freshness()

        def read(data: bytes) -> R:
            record = parse(data)
            if self.key.active:
                self.key.verify_content(record.auth, record.content)
                freshness.take(record)
            return record

        return read

    def call(self, topic: str, callback: Callable[..., T], *args: Any) -> T | None:
        """``callback(*args)``; None when it rejected its message or failed (counted)."""
        try:
            result = callback(*args)
        except MessageError as rejected:
            self.drop(topic, rejected.reason)
            return None
        except Exception as err:  # a defect of ours: counted and logged, never raised
            self.drop(topic, INTERNAL, f"{type(err).__name__}: {err}")
            return None
        self.accepted[topic] += 1
        return result

    def drop(self, topic: str, reason: str, detail: str | None = None) -> None:
        """Count a message of ``topic`` dropped for ``reason``; warn now and then.

        Counted by the reason's wording with its numbers left out, so that a
        flood of made-up ids adds one counter, not one per id.
        """
        self.dropped[(topic, _NUMBERS.sub("#", reason))] += 1
        detail = detail or reason
        now = self._node.get_clock().now().nanoseconds / 1e9
        if now - self._warned_at.get(topic, -math.inf) >= WARN_EVERY:
            self._warned_at[topic] = now
            total = sum(n for (where, _), n in self.dropped.items() if where == topic)
            self._node.get_logger().warning(
                f"dropped a message on {topic}: {detail} ({total} dropped so far)"
            )

    def publish(self) -> None:
        """Publish the counts on /diagnostics when they changed since the last time."""
        total = self.total_dropped + sum(self.accepted.values())
        if total == self._reported:
            return
        self._reported = total
        values = [
            KeyValue(key=f"accepted {topic}", value=str(n)) for topic, n in self.accepted.items()
        ]
        values += [
            KeyValue(key=f"heard bytes {topic}", value=str(n))
            for topic, n in self.heard_bytes.items()
        ]
        values += [
            KeyValue(key=f"dropped {topic}: {reason}", value=str(n))
            for (topic, reason), n in sorted(self.dropped.items())
        ]
        level = DiagnosticStatus.WARN if self.total_dropped else DiagnosticStatus.OK
        status = DiagnosticStatus(
            level=level,
            name=f"swazure: {self._node.get_fully_qualified_name()} inbound messages",
            message=f"{self.total_dropped} dropped",
            hardware_id=self._node.get_fully_qualified_name(),
            values=values,
        )
        array = DiagnosticArray(status=[status])
        array.header.stamp = self._node.get_clock().now().to_msg()
        self._diagnostics.publish(array)
