"""A swarm file on the command line: ``swazure spawn FILE``, ``swazure evaluate FILE``.

The file (``files.swarm_file``; read and checked by ``app.config.load_swarm_file``)
gives a verb's swarm options; a flag given on the command line overrides the
file's value, and an option that neither gives takes the flag's default.
``--beta`` or ``--radius`` on the command line replaces the file's size,
whichever of the two it gave.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..files.swarm_file import OPTIONS, find_swarm_file

#: The options that size the FLSs: one given on the command line replaces the file's.
SIZE = ("beta", "radius")


def swarm_file(text: str) -> Path:
    """A swarm file, as an argparse type: a path, or the bare name of an example."""
    try:
        return find_swarm_file(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_swarm_file_argument(
    parser: argparse.ArgumentParser,
    help: str = "a swarm file, or an example's name (config/swarms/: torus, trio, grid25, ...): "
    "these options as YAML, with every FLS's and one FLS's ROS parameters; a flag given here "
    "overrides the file",
) -> None:
    """The optional swarm file of a verb; call after every option is added."""
    parser.add_argument(
        "swarm_file",
        nargs="?",
        type=swarm_file,
        default=None,
        metavar="SWARM_FILE",
        help=help,
    )
    # A flag left out takes the file's value, then the flag's own default.
    defaults = {key: parser.get_default(key) for key in OPTIONS}
    parser.set_defaults(option_defaults=defaults, **dict.fromkeys(OPTIONS))


def apply_swarm_file(args: argparse.Namespace) -> argparse.Namespace:
    """``args`` with every option left out taken from the swarm file, else its default.

    Adds ``parameters`` (every FLS node's) and ``fls_parameters`` (FLS id ->
    its own) from the file, empty without one.
    """
    # Here: a verb's --help loads no world (sim/), which the config's module does.
    from ..app.config import load_swarm_file

    from_file = load_swarm_file(args.swarm_file) if args.swarm_file is not None else None
    size_given = any(getattr(args, key) is not None for key in SIZE)
    merged = argparse.Namespace(**vars(args))
    for key, default in args.option_defaults.items():
        if getattr(args, key) is not None:
            continue
        # The swarm's size on the command line replaces the file's, whichever it gave.
        replaced = from_file is None or (size_given and key in SIZE)
        value = None if replaced else getattr(from_file, key)
        setattr(merged, key, default if value is None else value)
    merged.parameters = {} if from_file is None else from_file.parameters
    merged.fls_parameters = {} if from_file is None else from_file.fls
    return merged
