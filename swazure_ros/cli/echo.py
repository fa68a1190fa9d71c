"""Print the messages of a topic in the YAML layout of ``ros2 topic echo``.

For machines that have only the ROS 2 wheels and no ``ros2`` command. The
message type is found on the graph, or given as pkg/msg/Type.
"""

from __future__ import annotations

import argparse
import signal
import sys

from .arguments import count, ros_topic, seconds
from .options import add_domain_argument


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure echo``."""
    parser.add_argument("topic", type=ros_topic, help="topic name, e.g. /swarm/measurements")
    parser.add_argument(
        "message_type", nargs="?", default=None, help="pkg/msg/Type (default: from the graph)"
    )
    parser.add_argument("--once", action="store_true", help="print one message and exit")
    parser.add_argument("--count", type=count, default=None, metavar="N", help="exit after N")
    parser.add_argument(
        "--timeout",
        type=seconds,
        default=None,
        metavar="S",
        help="exit 1 when no message arrived within S seconds (default: wait, saying once on "
        "stderr what it waits for)",
    )
    add_domain_argument(parser)


def main(args: argparse.Namespace) -> int:
    """Run ``swazure echo``."""
    from ..ros.clients.echo import echo

    # Ctrl-C stops the wait, as it says, also when a shell that started us in the
    # background made us ignore SIGINT (as `swazure spawn` does).
    signal.signal(signal.SIGINT, signal.default_int_handler)

    def write(text: str) -> None:
        sys.stdout.write(text)
        sys.stdout.flush()

    limit = 1 if args.once else args.count
    return echo(args.topic, args.message_type, limit, args.timeout, args.domain_id, write)
