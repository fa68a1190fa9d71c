"""Publish a recorded swarm run (``swazure spawn --record``) again, with its original timing.

Every message goes out on its recorded topic with the QoS it was recorded
with, as the bytes that were recorded; ``ros2 topic echo``, ``swazure echo``
and Foxglove see the run as it happened. With --rate 2 it plays twice as fast.
"""

from __future__ import annotations

import argparse
import sys
import time

from ..core.errors import SwazureError
from .arguments import number, recording, seconds
from .options import add_domain_argument


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
    from ..ros.plumbing.runtime import init_context
    from ..ros.recording.bag import Player, read_recording, recorded_channels

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
