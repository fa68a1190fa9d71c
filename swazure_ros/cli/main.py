"""``swazure``: the command-line entry point and verb dispatcher."""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import sys
from collections.abc import Iterable, Sequence
from types import ModuleType

from .. import __version__
from ..app.allocator import keep_freed_memory
from ..core.errors import RunError, SwazureError

#: Exit codes: a run that failed; the command line or its files unusable (argparse's).
RUN_FAILED, USAGE = 1, 2
EXIT_CODES = """\
exit codes:
  0    done; also a run that completed with a warning on stderr (every blind
       pair with no path: the warning says why and names --scale)
  1    the run failed: a swarm stalled, a process died, no answer in time, or
       (spawn --compute-all) the swarm's pairs are not the engine's
  2    the command line or its files are unusable (options, clouds, sensors,
       swarm and parameter files, an output folder)
  130  interrupted
  141  the reader of the output went away (a closed pipe)
"""

#: Verb name -> the first line of its module's docstring (a test keeps them equal). A
#: verb's module, with ``add_arguments(parser)`` and ``main(args) -> int``, is imported
#: only when the verb runs: `swazure --version` and `swazure --help` import none.
VERBS: dict[str, str] = {
    "evaluate": "Evaluate every ordered blind pair of a swarm with the core engine and "
    "report the metrics.",
    "study": "Run the published evaluation (spec section 10): every run, tables, figures "
    "and a report.",
    "spawn": "Bring up a swarm of FLS nodes (one rclpy node per FLS) and serve it until Ctrl-C.",
    "echo": "Print the messages of a topic in the YAML layout of ``ros2 topic echo``.",
    "query": "Ask a running swarm for one source FLS's pose relative to one blind neighbour.",
    "replay": "Publish a recorded swarm run (``swazure spawn --record``) again, with its "
    "original timing.",
    "track": "Track a moving FLS out of sight through a relay: true and estimated velocity "
    "and acceleration.",
    "camera": "Calibrate a sensor from a rendering ArUco camera (render, detect, solve with "
    "OpenCV).",
    "key": "Make a swarm's key: every process of one swarm is started with the same key file.",
    "compare": "Compare runs side by side: summaries, differences, error distributions, who did "
    "better where.",
}


#: The verbs whose program keeps the memory it frees (app.allocator): runs in blocks, and
#: a swarm whose processes allocate each phase's tables anew.
KEEPS_FREED_MEMORY = frozenset({"evaluate", "study", "spawn"})


def verb_module(name: str) -> ModuleType:
    """The module of verb ``name``."""
    return importlib.import_module(f"{__package__}.{name}")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # type: ignore[override]
        """Usage errors: one line and exit code 2, like argparse, without the usage block."""
        self.exit(USAGE, f"{self.prog}: error: {message}\n")


def build_parser(loaded: Iterable[str] | None = None) -> argparse.ArgumentParser:
    """The top-level parser with one subparser per verb; the ``loaded`` ones (all if None)
    with their options."""
    parser = _Parser(
        prog="swazure",
        epilog=EXIT_CODES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(
            "Swazure: Flying Light Specks compute their pose relative to neighbours "
            "too close for their own camera, through chains of sweet-range neighbours."
        ),
    )
    parser.add_argument("--version", action="version", version=f"swazure {__version__}")
    verbs = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    wanted = set(VERBS if loaded is None else loaded)
    for name, summary in VERBS.items():
        if name not in wanted:
            verbs.add_parser(name, help=summary)
            continue
        module = verb_module(name)
        sub = verbs.add_parser(name, help=summary, description=module.__doc__)
        module.add_arguments(sub)
        sub.set_defaults(handler=module.main)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one verb; the project's errors become one line on stderr and exit code 2, or 1
    for a run that failed (:class:`~swazure_ros.core.errors.RunError`)."""
    given = list(sys.argv[1:] if argv is None else argv)
    # Only the verb named is loaded (a verb is the first word that is not an option).
    named = next((word for word in given if not word.startswith("-")), None)
    if argv is None and named in KEEPS_FREED_MEMORY:
        keep_freed_memory()  # starts the program again, first, where it must
    parser = build_parser([named] if named in VERBS else [])
    args = parser.parse_args(given)
    if args.verb is None:
        parser.print_help()
        return USAGE
    code = _run(args)
    if getattr(args, "exit_process", False):
        # rclpy loads only for the verbs that use it: `swazure evaluate` starts faster.
        from ..ros.plumbing.process import exit_process

        exit_process(code)
    if argv is None:
        # This process ends next. Its interpreter's last collection walks every object
        # left, numba's typing tables among them (0.3 s of a chess evaluation's 2.7 s,
        # measured): frozen, they are left to the process's end, as the OS frees them.
        gc.freeze()
    return code


def _run(args: argparse.Namespace) -> int:
    """The verb's exit code; the project's errors become one line on stderr."""
    try:
        return int(args.handler(args))
    except SwazureError as err:
        print(f"swazure {args.verb}: error: {err}", file=sys.stderr)
        return RUN_FAILED if isinstance(err, RunError) else USAGE
    except MemoryError as err:
        # numpy's says what it could not allocate (a run past its address-space cap, or
        # the machine's memory); outputs are written atomically, so none is left half-made.
        detail = f": {err}" if str(err) else ""
        print(f"swazure {args.verb}: error: out of memory{detail}", file=sys.stderr)
        return RUN_FAILED
    except KeyboardInterrupt:
        print(f"swazure {args.verb}: interrupted", file=sys.stderr)
        _forget_interrupt()
        return 130
    except BrokenPipeError:
        # The reader went away (`swazure ... | head`): stop quietly, as cat does.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def _forget_interrupt() -> None:
    """Clear CPython's note that a KeyboardInterrupt went unhandled; the exit code stands.

    CPython notes it whenever a KeyboardInterrupt ends code that ``exec`` runs from a
    string (dataclasses and namedtuple make their methods so: any import may be
    in it), though the interrupt is caught later, and a process started as ``python -m``
    then ends by SIGINT instead of with 130 (a study stopped while it imported did so
    once in the suite). CPython clears the note each time it starts code from a string.
    """
    exec("")  # nothing runs: starting it is what clears the note


if __name__ == "__main__":
    sys.exit(main())
