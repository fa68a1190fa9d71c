"""``swazure``: the command-line entry point and verb dispatcher."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from types import ModuleType

from .. import __version__
from ..core.errors import SwazureError
from . import camera, echo, evaluate, key, query, replay, spawn, study, track

#: Verb name -> module with ``add_arguments(parser)`` and ``main(args) -> int``.
VERBS: dict[str, ModuleType] = {
    "evaluate": evaluate,
    "study": study,
    "spawn": spawn,
    "echo": echo,
    "query": query,
    "replay": replay,
    "track": track,
    "camera": camera,
    "key": key,
}


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        """Usage errors: one line and exit code 2, like argparse, without the usage block."""
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per verb."""
    parser = _Parser(
        prog="swazure",
        description=(
            "Swazure: Flying Light Specks compute their pose relative to neighbours "
            "too close for their own camera, through chains of sweet-range neighbours."
        ),
    )
    parser.add_argument("--version", action="version", version=f"swazure {__version__}")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    for name, module in VERBS.items():
        doc = (module.__doc__ or "").strip().splitlines()[0]
        sub = verbs.add_parser(name, help=doc, description=module.__doc__)
        module.add_arguments(sub)
        sub.set_defaults(handler=module.main)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one verb; the project's errors become one line on stderr and exit code 2."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.verb is None:
        parser.print_help()
        return 2
    code = _run(args)
    if getattr(args, "exit_process", False):
        # rclpy loads only for the verbs that use it: `swazure evaluate` starts faster.
        from ..ros.runtime import exit_process

        exit_process(code)
    return code


def _run(args: argparse.Namespace) -> int:
    """The verb's exit code; the project's errors become one line on stderr."""
    try:
        return int(args.handler(args))
    except SwazureError as err:
        print(f"swazure {args.verb}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"swazure {args.verb}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (`swazure ... | head`): stop quietly, as cat does.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == "__main__":
    sys.exit(main())
