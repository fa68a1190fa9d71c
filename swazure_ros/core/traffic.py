"""Messages and bytes per topic, and their totals: the one place a run's traffic is summed."""

from __future__ import annotations


class TopicCounts:
    """Messages and bytes per topic (serialised payloads); a subclass holds the two dicts."""

    messages: dict[str, int]
    bytes: dict[str, int]

    @property
    def total_messages(self) -> int:
        """Messages on every topic."""
        return sum(self.messages.values())

    @property
    def total_bytes(self) -> int:
        """Bytes on every topic."""
        return sum(self.bytes.values())
