"""Playing a recording back: its messages published again, as the bytes that were recorded.

A publisher sends CDR bytes as they are, so nothing is serialised to play a
recording. :class:`Player` offers each topic with the QoS it was recorded
with (rosbag2's rule over its publishers' offered profiles); ``swazure
replay`` keeps the original timing.
"""

from __future__ import annotations

import time
from typing import Any

from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from ...core.errors import SwazureError
from ..plumbing.interfaces import message_class
from .metadata import offered_profiles
from .reader import Channel, Recorded


class Player(Node):
    """Publishes recorded messages on their topics, with the QoS they were recorded with."""

    def __init__(self, channels: list[Channel], *, context: Context) -> None:
        super().__init__(
            "player", context=context, start_parameter_services=False, enable_rosout=False
        )
        self._by_topic: dict[str, Publisher] = {}
        for channel in channels:
            try:
                kind: Any = message_class(channel.type_name)
            except SwazureError as err:
                raise SwazureError(f"{channel.topic}: {err}") from err
            self._by_topic[channel.topic] = self.create_publisher(
                kind, channel.topic, _qos_of(channel.metadata)
            )

    def play(self, message: Recorded) -> None:
        """Publish ``message``'s bytes as they were recorded."""
        self._by_topic[message.topic].publish(message.data)

    def unacknowledged(self, timeout: float) -> list[str]:
        """The topics whose reliable readers have not acknowledged every message within
        ``timeout`` s (all of them waited for at once)."""
        deadline = time.monotonic() + timeout
        return [
            topic
            for topic, publisher in self._by_topic.items()
            if not publisher.wait_for_all_acked(
                Duration(seconds=max(deadline - time.monotonic(), 0.0))
            )
        ]


def _qos_of(metadata: dict[str, str]) -> QoSProfile:
    """The publisher QoS of a recorded topic: rosbag2's rule over the offered profiles.

    Reliable and latched when every publisher offered it; from our first
    recordings' own keys where there are no profiles (reliable, volatile when
    not said).
    """
    offers = offered_profiles(metadata)  # none: reliable and volatile
    reliable = all(o.get("reliability") in ("reliable", 1) for o in offers)
    latched = bool(offers) and all(o.get("durability") in ("transient_local", 1) for o in offers)
    return QoSProfile(
        history=HistoryPolicy.KEEP_ALL,
        depth=1,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )
