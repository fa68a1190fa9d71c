"""A process's own messages heard back: DDS delivers what a process publishes to its own
readers of the topic too, and a radio must not take its own offers twice."""

from __future__ import annotations

from collections import Counter, deque


class Echoes:
    """The last ``size`` messages sent, by their bytes: DDS brings a process its own back."""

    def __init__(self, size: int) -> None:
        self._order: deque[bytes] = deque()
        self._held: Counter[bytes] = Counter()
        self._size = size

    def add(self, data: bytes) -> None:
        """Remember ``data``, forgetting the oldest beyond the size."""
        self._order.append(data)
        self._held[data] += 1
        while len(self._order) > self._size:
            old = self._order.popleft()
            self._held[old] -= 1
            if not self._held[old]:
                del self._held[old]

    def __call__(self, data: bytes) -> bool:
        """True if ``data`` is one of the messages sent lately."""
        return data in self._held
