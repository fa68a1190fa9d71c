"""Types of command-line values, checked once where options are parsed, for every verb.

Each is an argparse ``type``: it returns the value or raises
``argparse.ArgumentTypeError`` with the reason, which argparse prints as one
line (``swazure VERB: error: argument --x: reason``) with exit code 2.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from ..core.errors import CloudError
from ..files import values
from ..files.reading import total_memory

T = TypeVar("T")


def _option_type(rule: Callable[[str], T]) -> Callable[[str], T]:
    """``rule`` (files.values: shared with the swarm file) as an argparse type: the
    rule's ValueError becomes argparse's one line with exit code 2."""

    @functools.wraps(rule)
    def checked(text: str) -> T:
        try:
            return rule(text)
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err)) from None

    return checked


whole_number = _option_type(values.whole_number)
number = _option_type(values.number)
seed = _option_type(values.seed)
count = _option_type(values.count)
resample_count = _option_type(values.resample_count)
domain_id = _option_type(values.domain_id)
fls_id = _option_type(values.fls_id)
seconds = _option_type(values.seconds)
input_file = _option_type(values.input_file)

#: Units of a memory size: bytes per unit (binary: K is 1024 bytes).
_SIZE_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def memory_size(text: str) -> int:
    """A memory size such as 512M or 4G (binary units), at least 64M and at most the
    machine's memory: bytes."""
    stripped = text.strip().upper().removesuffix("IB").removesuffix("B")
    unit = stripped[-1:] if stripped[-1:] in _SIZE_UNITS else ""
    try:
        value = float(stripped[: len(stripped) - len(unit)])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a memory size such as 512M or 4G"
        ) from None
    size = value * _SIZE_UNITS[unit]
    if not math.isfinite(size) or size < 64 * 2**20:
        raise argparse.ArgumentTypeError(f"{text!r}: give at least 64M")
    machine = total_memory()
    if size > machine:
        # Blocks that large could never be held: the run would swap, or be killed, first.
        raise argparse.ArgumentTypeError(
            f"{text!r}: more than this machine's {machine / 2**30:.1f}G of memory"
        )
    return int(size)


def threshold(text: str) -> int:
    """Move Source's threshold T: 1 to MAX_THRESHOLD steps of r."""
    from ..core.heuristics.result import MAX_THRESHOLD

    value = whole_number(text)
    if not 1 <= value <= MAX_THRESHOLD:
        raise argparse.ArgumentTypeError(
            f"{value}: must be 1 to {MAX_THRESHOLD} steps of r (each probes 26 directions)"
        )
    return value


def port(text: str) -> int:
    """A TCP port, 0 (any free one) to 65535."""
    value = whole_number(text)
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{value} is outside 0..65535")
    return value


def fls_pairs(text: str) -> tuple[tuple[int, int], ...]:
    """``I:J,K:L``: ordered pairs of FLS ids (source:target)."""
    pairs = []
    for item in text.split(","):
        source, colon, target = item.partition(":")
        if not colon:
            raise argparse.ArgumentTypeError(f"{item!r}: expected SOURCE:TARGET, e.g. 3:17")
        pairs.append((fls_id(source), fls_id(target)))
    return tuple(pairs)


def distance_mm(text: str) -> float:
    """A distance in millimetres, finite and above 0."""
    value = number(text)
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text} mm: a distance must be above 0")
    return value


def ros_namespace(text: str) -> str:
    """A ROS namespace without its leading slash, e.g. ``swarm`` or ``show/left``."""
    # Here: rclpy loads only for a verb given a namespace.
    from ..ros.plumbing.names import checked_namespace

    return _option_type(checked_namespace)(text)


def share(text: str) -> tuple[int, int]:
    """``K/N``: share K (0-based) of a swarm split over N hosts."""
    index, slash, hosts = text.partition("/")
    if not slash:
        raise argparse.ArgumentTypeError(f"{text!r}: expected K/N, e.g. 0/3")
    k, n = whole_number(index), whole_number(hosts)
    if n < 1 or not 0 <= k < n:
        raise argparse.ArgumentTypeError(f"{text}: need 0 <= K < N")
    return k, n


def discovery_servers(text: str) -> tuple[Any, ...]:
    """``IP[:PORT],...``: Fast DDS Discovery Servers (app.discovery_server.ServerAddress)."""
    from ..app.discovery_server import parse_servers

    try:
        return parse_servers(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def ros_topic(text: str) -> str:
    """A fully qualified ROS topic name (a leading slash is added when missing)."""
    from ..ros.plumbing.names import topic_problem

    name = text if text.startswith("/") else f"/{text}"
    reason = topic_problem(name)
    if reason is not None:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a ROS topic name ({reason}; use letters, digits, _ and /)"
        )
    return name


def viewing_angle(text: str) -> float:
    """A viewing angle of a marker, degrees: 0 (head-on) up to, not including, 90."""
    value = number(text)
    if not 0 <= value < 90:
        raise argparse.ArgumentTypeError(f"{text}: a viewing angle is in [0, 90) degrees")
    return value


def _writable_folder_for(path: Path) -> None:
    """Raise unless ``path``'s nearest existing ancestor is a folder this process can write."""
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise argparse.ArgumentTypeError(f"{path}: {ancestor} is not a folder")
    if not os.access(ancestor, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"{path}: cannot write in {ancestor}")


def output_folder(text: str) -> Path:
    """A folder to write results into: made when absent; not an existing file."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{path} exists and is not a folder")
    if not path.exists():
        _writable_folder_for(path)
    elif not os.access(path, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"{path}: cannot write in this folder")
    return path


def output_file(text: str) -> Path:
    """A file to write: not a folder, in a folder that can be written (or made)."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{path} is a folder, not a file")
    _writable_folder_for(path)
    return path


def png_file(text: str) -> Path:
    """A PNG file to write."""
    path = output_file(text)
    if path.suffix.lower() != ".png":
        raise argparse.ArgumentTypeError(f"{path}: figures are written as PNG (name it .png)")
    return path


def bag_folder(text: str) -> Path:
    """A rosbag2 bag folder to write: a new one, as ``ros2 bag record -o`` makes."""
    path = Path(text)
    if path.suffix.lower() == ".mcap":
        raise argparse.ArgumentTypeError(
            f"{path}: a recording is a bag folder (metadata.yaml and its MCAP file): "
            "name the folder, without .mcap"
        )
    if path.exists():
        raise argparse.ArgumentTypeError(f"{path} exists: a recording makes a new bag folder")
    _writable_folder_for(path)
    return path


def recording(text: str) -> Path:
    """A recording to read: a bag folder (with metadata.yaml), or an MCAP file.

    A folder of MCAP files without metadata.yaml is a recording that a full
    disk cut short (``ros.recording.recorder.Recorder``): read as far as it was written.
    """
    path = Path(text)
    if path.is_dir() and not (path / "metadata.yaml").is_file() and not any(path.glob("*.mcap")):
        raise argparse.ArgumentTypeError(f"{path}: a folder without metadata.yaml is not a bag")
    return path if path.is_dir() else input_file(text)


def check_beta_or_radius(beta: float | None, radius: float | None) -> None:
    """One of beta or radius sizes the FLSs: CloudError when the options, swarm file
    included, give neither (argparse refuses both on the command line, the swarm file both
    in the file, and a flag replaces the file's)."""
    if beta is not None and radius is not None:
        raise CloudError("give --beta or --radius, not both")
    if beta is None and radius is None:
        raise CloudError("give --beta (r = beta * dmin) or --radius (cm)")
