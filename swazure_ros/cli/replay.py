"""Publish a recorded swarm run (``swazure spawn --record``) again, with its original timing.

Every message goes out on its recorded topic with the QoS it was recorded
with, as the bytes that were recorded; ``ros2 topic echo``, ``swazure echo``
and Foxglove see the run as it happened. With --rate 2 it plays twice as fast.
With --info it publishes nothing and tells what the recording holds, as
``ros2 bag info`` does: files, size, duration, start and end, and per topic its
type, message count and its publishers' offered QoS.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from collections.abc import Sequence
from datetime import datetime, timezone
from typing import TYPE_CHECKING

from ..core.errors import SwazureError
from .arguments import number, recording, seconds
from .options import add_domain_argument

if TYPE_CHECKING:
    from ..ros.recording.metadata import OfferedProfile
    from ..ros.recording.reader import BagInfo


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure replay``."""
    parser.add_argument(
        "recording",
        type=recording,
        metavar="BAG",
        help="a recording: a bag folder (swazure spawn --record, ros2 bag record -s mcap) or "
        "an MCAP file",
    )
    parser.add_argument(
        "--rate", type=rate, default=1.0, help="play this many times faster (default 1)"
    )
    parser.add_argument(
        "--delay",
        type=seconds,
        default=1.0,
        metavar="S",
        help="wait S seconds between advertising the topics and the first message, so that "
        "subscribers can match (default 1)",
    )
    parser.add_argument(
        "--info",
        action="store_true",
        help="publish nothing: print what the recording holds (files, size, duration, start "
        "and end, and per topic its type, message count and offered QoS), as ros2 bag info",
    )
    add_domain_argument(parser)


#: Seconds the replay waits, at its end, for reliable readers to acknowledge what it sent.
#: It ends as soon as they have: the wait is long for a reader on a busy machine, which
#: acknowledges late, not never.
ACK_WAIT = 60.0
#: Playback rates, slowest and fastest: a thousandth plays a second's recording in
#: 17 minutes; faster than a thousand times, messages would only queue up.
RATES = (1e-3, 1e3)


def rate(text: str) -> float:
    """A playback rate, from RATES[0] to RATES[1]."""
    value = number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"{text}: a rate must be above 0")
    if not RATES[0] <= value <= RATES[1]:
        raise argparse.ArgumentTypeError(
            f"{text}: a rate must be from {RATES[0]:g} to {RATES[1]:g}"
        )
    return value


def main(args: argparse.Namespace) -> int:
    """Run ``swazure replay``."""
    from ..ros.plumbing.process import init_context
    from ..ros.recording.player import Player
    from ..ros.recording.reader import bag_info, read_recording, recorded_channels

    if args.info:
        sys.stdout.write(info_text(bag_info(args.recording)))
        return 0
    channels = recorded_channels(args.recording)
    if not channels:
        raise SwazureError(f"{args.recording}: no ROS 2 messages recorded")
    context = init_context(args.domain_id)
    player = Player(channels, context=context)
    played = 0
    try:
        time.sleep(args.delay)
        began, first = time.monotonic(), None
        try:
            for message in read_recording(args.recording):
                first = message.log_time if first is None else first
                due = began + (message.log_time - first) / 1e9 / args.rate
                wait = due - time.monotonic()
                if wait > 0:
                    time.sleep(wait)
                player.play(message)
                played += 1
        except SwazureError as err:
            # What came before the damage was played; the one line says so.
            raise SwazureError(f"{err}; replayed the {played} messages before it") from err
        # Every reliable reader has every message before we leave, or we say which not.
        unacknowledged = player.unacknowledged(ACK_WAIT)
    finally:
        player.destroy_node()  # type: ignore[no-untyped-call]
        context.try_shutdown()
    print(
        f"replayed {played} messages on {len(channels)} topics in "
        f"{time.monotonic() - began:.1f} s; "
        + (
            "every reliable reader acknowledged every message"
            if not unacknowledged
            else f"not acknowledged by every reliable reader within {ACK_WAIT:g} s: "
            + ", ".join(unacknowledged)
        ),
        file=sys.stderr,
    )
    return 0


#: The width of info_text's labels, as ros2 bag info aligns them.
_LABEL = 19


def info_text(info: BagInfo) -> str:
    """What a recording holds, laid out as ``ros2 bag info`` lays it out (times in UTC)."""
    lines = [
        ("Files:", ", ".join(str(path.name) for path in info.files)),
        ("Bag size:", _size(info.size)),
        ("Storage id:", info.storage),
        ("ROS Distro:", info.ros_distro),
        ("Duration:", f"{info.duration / 1e9:.9f}s"),
        ("Start:", _time(info.start) if info.count else "-"),
        ("End:", _time(info.end) if info.count else "-"),
        ("Messages:", str(info.count)),
    ]
    if info.cut is not None:
        lines.append(("Cut short:", info.cut))
    topics = [
        f"Topic: {topic.name} | Type: {topic.type_name} | Count: {topic.count} | "
        f"Serialization Format: {topic.serialization_format} | "
        f"Offered QoS: {offered_qos_text(topic.offered_qos)}"
        for topic in sorted(info.topics, key=lambda topic: topic.name)
    ]
    lines.append(("Topic information:", topics[0] if topics else "-"))
    lines += [("", line) for line in topics[1:]]
    return "".join(f"{label:<{_LABEL}}{value}\n" for label, value in lines)


def offered_qos_text(profiles: Sequence[OfferedProfile]) -> str:
    """Publishers' QoS profiles in a few words: reliability and durability, with how many
    publishers offer each (``reliable, transient_local x60``); "-" when none is recorded."""
    offers = Counter(
        f"{profile.get('reliability', '?')}, {profile.get('durability', '?')}"
        for profile in profiles
    )
    return "; ".join(f"{offer} x{count}" for offer, count in offers.items()) or "-"


def _size(count: int) -> str:
    """Bytes as ros2 bag info says them (B, KiB, MiB, GiB)."""
    size, unit = float(count), "B"
    for larger in ("KiB", "MiB", "GiB"):
        if size < 1024:
            break
        size, unit = size / 1024, larger
    return f"{size:.1f} {unit}" if unit != "B" else f"{count} B"


def _time(ns: int) -> str:
    """A time in ns since the epoch, as a UTC date and the seconds (``ros2 bag info``'s)."""
    seconds, rest = divmod(ns, 10**9)
    when = datetime.fromtimestamp(seconds, tz=timezone.utc).strftime("%b %d %Y %H:%M:%S")
    return f"{when}.{rest:09d} UTC ({seconds}.{rest:09d})"
