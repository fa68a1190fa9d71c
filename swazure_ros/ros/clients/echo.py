"""A topic's messages printed as ``ros2 topic echo`` prints them, for ``swazure echo``.

For machines that have only the ROS 2 wheels and no ``ros2`` command. The
message type is found on the graph, or given as pkg/msg/Type.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable
from typing import Any

import yaml
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ...core.errors import RunError, SwazureError
from ..plumbing.interfaces import message_class
from ..plumbing.node import SwarmNode
from ..plumbing.process import init_context


def message_to_dict(message: Any) -> Any:
    """A message as nested dicts and lists, fields in declaration order."""
    if hasattr(message, "get_fields_and_field_types"):
        return {
            field: message_to_dict(getattr(message, field))
            for field in message.get_fields_and_field_types()
        }
    if isinstance(message, (list, tuple)) or type(message).__name__ in ("array", "ndarray"):
        return [message_to_dict(item) for item in message]
    if isinstance(message, bytes):
        return list(message)
    return message.item() if hasattr(message, "item") else message


class _Dumper(yaml.SafeDumper):
    """Keep field order, as ros2 topic echo does."""


_Dumper.add_representer(dict, lambda dumper, data: dumper.represent_dict(data.items()))


def message_to_yaml(message: Any) -> str:
    """A message as the YAML block ``ros2 topic echo`` prints (without the ``---``)."""
    return yaml.dump(
        message_to_dict(message), Dumper=_Dumper, default_flow_style=False, width=sys.maxsize
    )


ECHO_DEPTH = 10_000
#: Seconds echo waits quietly before it says what it waits for: a publisher that is
#: there shows on the graph within this on a quiet machine, and then nothing is said.
WAIT_NOTICE_AFTER = 2.0


class WaitNotice:
    """Says once on stderr, when nothing came within ``grace`` s, what echo waits for.

    A reader that waits in silence looks hung: the line names the topic, its
    namespace, the ROS domain and discovery range it looks on, what the graph
    shows there, and what ends the wait.
    """

    def __init__(
        self, topic: str, timeout: float | None, grace: float = WAIT_NOTICE_AFTER
    ) -> None:
        self.topic, self.timeout = topic, timeout
        self._due = time.monotonic() + grace
        #: The line, once said.
        self.said: str | None = None

    def look(self, node: Node, printed: int) -> None:
        """Say it now if its time came and nothing was printed (once)."""
        if self.said is not None or printed or time.monotonic() < self._due:
            return
        self.said = waiting_text(node, self.topic, self.timeout)
        print(self.said, file=sys.stderr, flush=True)


def waiting_text(node: Node, topic: str, timeout: float | None) -> str:
    """One line: what ``swazure echo`` waits for on ``node``'s domain, and what ends it."""
    namespace = topic.rsplit("/", 1)[0] or "/"
    publishers = node.count_publishers(topic)
    waited = f"a message on {topic} ({publishers} publishers)" if publishers else (
        f"a publisher of {topic}"
    )  # fmt: skip
    prefix = namespace.rstrip("/") + "/"
    others = [name for name, _ in node.get_topic_names_and_types() if name.startswith(prefix)]
    seen = f"{len(others)} topics under {namespace} seen" if others else (
        f"no topic under {namespace} seen yet"
    )  # fmt: skip
    reach = os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET").lower()
    ends = f"it ends after {timeout:g} s (--timeout)" if timeout is not None else (
        "--timeout S ends the wait, Ctrl-C stops"
    )  # fmt: skip
    domain = node.context.get_domain_id()
    return (
        f"swazure echo: waiting for {waited} in namespace {namespace}, ROS domain {domain} "
        f"(discovery: {reach}); {seen}; {ends}"
    )


def echo_qos(node: Node, topic: str) -> QoSProfile:
    """A reader's QoS that gets what ``topic``'s publishers offer, as ``ros2 topic echo`` does.

    Transient local when every publisher latches (a late reader then gets each
    one's last message), best effort when any publisher is best effort. A
    reliable reader keeps all: a late reader of a swarm's latched messages gets
    one per FLS at once, whatever the swarm's size, and a burst of a round
    (hundreds of messages) waits while the printing catches up; a depth of 10
    dropped most of a heuristic's moves and 41 of the example torus's 120
    measurements.
    """
    offered = node.get_publishers_info_by_topic(topic)
    latched = bool(offered) and all(
        info.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for info in offered
    )
    best_effort = any(
        info.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for info in offered
    )
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST if best_effort else HistoryPolicy.KEEP_ALL,
        depth=ECHO_DEPTH,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
    )


def _spin(executor: SingleThreadedExecutor, step: Callable[[], object] | None) -> None:
    """Spin once; then ``step()``, what serves a swarm that this process runs, if any."""
    executor.spin_once(timeout_sec=0.1 if step is None else 0.01)
    if step is not None:
        step()


def echo(
    topic: str,
    type_name: str | None,
    limit: int | None,
    timeout: float | None,
    domain_id: int | None,
    write: Callable[[str], object],
    take: Callable[[Any], object] | None = None,
    step: Callable[[], object] | None = None,
) -> int:
    """Write each message of ``topic`` as YAML and ``---`` until ``limit``; the exit status.

    Waits for a publisher when ``type_name`` is None; the reader takes the
    publishers' QoS (echo_qos) once they show; 1 when no message came within
    ``timeout`` seconds. With ``take``, each message goes to it instead of ``write``;
    ``step`` is called between spins (what serves a swarm this process runs).
    """
    context = init_context(domain_id)
    node = SwarmNode("swazure_echo", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    printed = 0
    began = time.monotonic()
    notice = WaitNotice(topic, timeout)
    try:
        if type_name is None:
            type_name = _published_type(node, executor, topic, timeout, notice, step)
        cls = message_class(type_name)
        wanted = f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"

        def on_message(message: Any) -> None:
            nonlocal printed
            if limit is None or printed < limit:
                if take is None:
                    write(message_to_yaml(message) + "---\n")
                else:
                    take(message)
                printed += 1

        # With the type given, the reader is there at once, as a person watching a topic
        # before its publishers start expects; its QoS is then a guess (volatile when
        # no publisher is known yet), made again once publishers show.
        # Asked before the QoS is chosen: publishers that show in between are then
        # looked at again, never missed.
        guessed = not node.get_publishers_info_by_topic(topic)
        qos = echo_qos(node, topic)
        subscription = node.create_subscription(cls, topic, on_message, qos)
        while limit is None or printed < limit:
            publishers = node.get_publishers_info_by_topic(topic)
            offered = sorted({info.topic_type for info in publishers})
            if offered and wanted not in offered:
                # A subscription of another type never matches: say so instead of waiting.
                raise SwazureError(f"{topic} carries {', '.join(offered)}, not {wanted}")
            if guessed and publishers:
                guessed = False
                found = echo_qos(node, topic)
                if not printed and found != qos:
                    # Latched publishers: a volatile reader would skip what they sent
                    # before it matched them, and a swarm at rest sends nothing more.
                    node.destroy_subscription(subscription)
                    qos = found
                    subscription = node.create_subscription(cls, topic, on_message, qos)
            if timeout is not None and not printed and time.monotonic() - began > timeout:
                print(
                    f"swazure echo: no message on {topic} within {timeout:g} s",
                    file=sys.stderr,
                )
                return 1
            notice.look(node, printed)
            _spin(executor, step)
    finally:
        executor.shutdown()
        node.destroy_node()  # type: ignore[no-untyped-call]
        context.try_shutdown()
    return 0


def _published_type(
    node: Node,
    executor: SingleThreadedExecutor,
    topic: str,
    timeout: float | None,
    notice: WaitNotice,
    step: Callable[[], object] | None,
) -> str:
    """The type of ``topic`` once a publisher shows; RunError after ``timeout`` s.

    ``step`` serves a swarm this process runs between spins (see `echo`).
    """
    began = time.monotonic()
    while True:
        types = dict(node.get_topic_names_and_types()).get(topic)
        if types:
            return str(types[0])
        if timeout is not None and time.monotonic() - began > timeout:
            raise RunError(f"{topic}: no publisher found within {timeout:g} s")
        notice.look(node, 0)
        _spin(executor, step)
