"""The swarm instance: announced by the world node, taken by the hosts that share a key file.

Every tag covers the swarm instance (:mod:`.auth`), 16 random bytes made when
the swarm starts. A swarm started whole hands it to its processes with the
key. Hosts started one by one with a key file learn it from the world node,
which announces it every second; an announcement is taken only if it is
stamped within ``ANNOUNCEMENT_FRESH`` of the taker's own wall clock, so an
announcement recorded from an earlier swarm and played back is refused.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from builtin_interfaces.msg import Time
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from std_msgs.msg import Header
from swazure_interfaces.msg import SwarmInstance

from ...core.errors import MessageError, RunError
from ..convert.units import stamp_nanoseconds
from ..plumbing.names import INSTANCE_QOS, INSTANCE_TOPIC
from ..plumbing.process import Context
from ..plumbing.startup import StartupValues
from ..security.auth import ANNOUNCEMENT, INSTANCE_BYTES, Freshness, SwarmKey
from ..security.keys import key_from

#: Seconds between two announcements of the instance.
ANNOUNCEMENT_PERIOD = 1.0
#: Seconds an announcement's stamp may be from the taker's clock (hosts keep time by NTP).
ANNOUNCEMENT_FRESH = 10.0
#: Seconds a program started by hand waits for the world node's announcement.
PROGRAM_WAIT = 60.0


def announcement(key: SwarmKey) -> SwarmInstance:
    """``key``'s instance, stamped now by the wall clock and signed for every instance."""
    now = time.time_ns()
    stamp = Time(sec=now // 1_000_000_000, nanosec=now % 1_000_000_000)
    message = SwarmInstance(header=Header(stamp=stamp), instance=key.instance)
    return key.for_instance(ANNOUNCEMENT).sign(message)


def announced(message: SwarmInstance, key: SwarmKey, now_ns: int) -> bytes:
    """The instance ``message`` announces; MessageError if not signed, or stale by ``now_ns``."""
    key.for_instance(ANNOUNCEMENT).verify(message)
    age = abs(now_ns - stamp_nanoseconds(message.header.stamp)) / 1e9
    if age > ANNOUNCEMENT_FRESH:
        raise MessageError(f"an announcement {age:.0f} s from now: a replay or a stale clock")
    instance = bytes(message.instance)
    if len(instance) != INSTANCE_BYTES:
        raise MessageError(f"an instance of {len(instance)} bytes, not {INSTANCE_BYTES}")
    return instance


class Announcer:
    """Announces ``key``'s instance on ``node`` every ANNOUNCEMENT_PERIOD seconds."""

    def __init__(self, node: Node, key: SwarmKey) -> None:
        self._key = key
        self._publisher = node.create_publisher(SwarmInstance, INSTANCE_TOPIC, INSTANCE_QOS)
        self.announce()
        node.create_timer(ANNOUNCEMENT_PERIOD, self.announce)

    def announce(self) -> None:
        """Publish the instance, stamped now."""
        self._publisher.publish(announcement(self._key))


def await_instance(
    context: Context,
    namespace: str,
    key: bytes,
    timeout: float,
    on_refused: Callable[[str], None] = lambda reason: None,
) -> bytes:
    """The instance the swarm's world node announces, within ``timeout`` s; SwazureError if none.

    ``on_refused(reason)``: an announcement not taken (not signed, stale).
    """
    keyed = SwarmKey(key, bytes(INSTANCE_BYTES))
    freshness = Freshness()
    found: list[bytes] = []

    def take(message: SwarmInstance) -> None:
        try:
            freshness.take(message)
            found.append(announced(message, keyed, time.time_ns()))
        except MessageError as refused:
            on_refused(refused.reason)

    node = Node("swazure_instance_taker", namespace=namespace, context=context)
    executor = SingleThreadedExecutor(context=context)
    try:
        node.create_subscription(SwarmInstance, INSTANCE_TOPIC, take, INSTANCE_QOS)
        executor.add_node(node)
        deadline = time.monotonic() + timeout
        while not found and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        if not found:
            raise RunError(
                f"no world node announced the swarm's instance on /{namespace}/{INSTANCE_TOPIC} "
                f"in {timeout:g} s: start the world too (`swazure spawn --share 0/N`, or `ros2 "
                "run swazure_ros world`), with the same key file and a clock within "
                f"{ANNOUNCEMENT_FRESH:g} s of this one's"
            )
    finally:
        executor.shutdown()
        node.destroy_node()
    return found[-1]


def program_key(context: Context, values: StartupValues, *, world: bool = False) -> SwarmKey:
    """The SwarmKey of a program from its ``key_file`` and ``swarm_instance`` parameters.

    Without a given instance, the world's program makes a fresh one and every
    other program waits for the world node's announcement.
    """
    key = key_from(str(values["key_file"]))
    text = str(values["swarm_instance"])
    instance = None
    if text:
        # Read by startup.SWARM_INSTANCE's rule: 2 * INSTANCE_BYTES hexadecimal digits.
        instance = bytes.fromhex(text)
    elif key is not None and not world:
        instance = await_instance(context, str(values["namespace"]), key, PROGRAM_WAIT)
    return SwarmKey(key, instance)
