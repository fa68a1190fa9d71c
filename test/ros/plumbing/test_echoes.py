"""A process's own messages heard back: the last few sent, known by their bytes."""

from __future__ import annotations

from swazure_ros.ros.plumbing.echoes import Echoes


def test_the_last_messages_sent_are_known_and_older_ones_forgotten():
    echoes = Echoes(3)
    for data in (b"a", b"b", b"a", b"c"):
        echoes.add(data)
    # Four sent, three kept (b, a, c): the first a is forgotten, its second sending is not.
    assert echoes(b"a") and echoes(b"b") and echoes(b"c")
    assert not echoes(b"never sent")
    echoes.add(b"d")  # b goes
    assert not echoes(b"b") and echoes(b"a")
    echoes.add(b"e")  # the second a goes
    assert not echoes(b"a") and echoes(b"c") and echoes(b"d") and echoes(b"e")
