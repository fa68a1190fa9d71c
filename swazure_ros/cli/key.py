"""Make a swarm's key: every process of one swarm is started with the same key file.

Every protocol message of a swarm is signed with its key, and a message
that it does not sign is dropped (docs/security.md). ``swazure spawn`` makes
a fresh key for a swarm it starts whole; a swarm across hosts needs one key
file, copied to every host: ``swazure spawn --key-file FILE`` (or
``SWAZURE_SWARM_KEY_FILE=FILE``).
"""

from __future__ import annotations

import argparse

from ..core.errors import SwazureError
from ..ros.security.keys import new_key, write_key
from .arguments import output_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``swazure key``."""
    parser.add_argument("file", type=output_file, metavar="FILE", help="the key file to write")
    parser.add_argument("--force", action="store_true", help="replace an existing key file")


def main(args: argparse.Namespace) -> int:
    """Write a new key file; refuse to replace one unless asked."""
    if args.file.exists() and not args.force:
        raise SwazureError(f"{args.file}: exists; --force replaces it (a swarm's old key with it)")
    write_key(args.file, new_key())
    print(f"wrote a new swarm key to {args.file} (mode 600); start every share with --key-file")
    return 0
