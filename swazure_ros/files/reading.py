"""Reading the files people give: regular files of bounded size, YAML of bounded expansion.

A path may name a FIFO, a device or a file of gigabytes, and a YAML file
may hold an alias bomb (a few lines that expand to billions of nodes) or
nesting deep enough to exhaust the parser's recursion. Every reader of a
file a person names checks it with :func:`regular_file` before it opens it
(opening a FIFO blocks until a writer comes; reading /dev/zero never ends),
most through :func:`read_bytes` or :func:`read_yaml`, which refuse those
with one line before any time or memory is spent. The command line's file
arguments and a swarm file's paths (``files.values.input_file``) take the same check.
"""

from __future__ import annotations

import os
import resource
import stat
import sys
from pathlib import Path
from typing import Any

import yaml

from ..core.errors import SensorError, SwazureError

#: Bytes of a configuration file (sensor, camera, swarm, parameters), at most.
CONFIG_BYTES = 4 * 2**20
#: Bytes of a table people give (waypoints, a measured camera), at most: an hour's
#: waypoints at 100 Hz are 15 MB.
TABLE_BYTES = 64 * 2**20
#: Nodes of one YAML document with every alias expanded, at most (a configuration
#: file holds hundreds).
YAML_NODES = 100_000
#: Nesting of YAML collections, at most.
YAML_DEPTH = 50


def regular_file(path: Path, kind: str, limit: int | None, error: type[SwazureError]) -> Path:
    """``path`` if a regular file of at most ``limit`` bytes (None: any size); ``error`` in one
    line if not: absent, a folder, or a FIFO, a device or a socket, which are refused by
    their status, before any open that could block or read without end."""
    what = f"{kind} file" if kind else "file"
    try:
        status = path.stat()
    except FileNotFoundError as err:
        raise error(f"{path}: no such {what}") from err
    except OSError as err:
        raise error(f"{path}: cannot read ({err.strerror or err})") from err
    if stat.S_ISDIR(status.st_mode):
        raise error(f"{path}: is a folder, expected a {what}")
    if not stat.S_ISREG(status.st_mode):
        raise error(f"{path}: not a regular file (a pipe or a device?), expected a {what}")
    if limit is not None and status.st_size > limit:
        raise error(
            f"{path}: {status.st_size / 2**20:.1f} MiB, more than a {what} may be "
            f"({limit / 2**20:.0f} MiB)"
        )
    return path


def read_bytes(path: Path, kind: str, limit: int, error: type[SwazureError]) -> bytes:
    """The content of regular file ``path`` (at most ``limit`` bytes); ``error`` if not."""
    regular_file(path, kind, limit, error)
    try:
        with open(path, "rb") as handle:
            data = handle.read(limit + 1)
    except OSError as err:
        raise error(f"{path}: cannot read ({err.strerror or err})") from err
    if len(data) > limit:
        raise error(f"{path}: more than a {kind} file may be ({limit / 2**20:.0f} MiB)")
    return data


def read_text(path: Path, kind: str, limit: int, error: type[SwazureError]) -> str:
    """The UTF-8 text of regular file ``path`` (at most ``limit`` bytes); ``error`` if not."""
    try:
        return read_bytes(path, kind, limit, error).decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{path}: not a text file") from err


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader that refuses alias bombs and deep nesting.

    It counts the nodes a document holds with every alias expanded (an
    anchored node's count is added again at each alias to it), so that a few
    lines that would expand to billions of nodes are refused as they are read.
    """

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._expanded = 0
        self._weights: dict[str, int] = {}
        self._depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()  # type: ignore[no-untyped-call]
        anchor = getattr(event, "anchor", None)
        if isinstance(event, yaml.AliasEvent):
            self._count(self._weights.get(anchor or "", 1))
            return super().compose_node(parent, index)
        before = self._expanded
        self._count(1)
        self._depth += 1
        try:
            if self._depth > YAML_DEPTH:
                raise yaml.YAMLError(f"nested more than {YAML_DEPTH} deep")
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        if anchor is not None:
            self._weights[anchor] = self._expanded - before
        return node

    def _count(self, nodes: int) -> None:
        self._expanded += nodes
        if self._expanded > YAML_NODES:
            raise yaml.YAMLError(
                f"more than {YAML_NODES:,} nodes with its aliases expanded (an alias bomb?)"
            )


def read_yaml(path: Path, kind: str, error: type[SwazureError]) -> Any:
    """The parsed YAML document of a ``kind`` file; ``error`` in one line if it has none."""
    text = read_text(path, kind, CONFIG_BYTES, error)
    try:
        return yaml.load(text, Loader=_BoundedLoader)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or (str(err) if not mark else "")
        detail = f": {problem}" if problem else ""
        raise error(f"{path}: not valid YAML{where} for a {kind} file{detail}") from err


def config_dir() -> Path:
    """The folder of the project's YAML configuration (``config/``)."""
    candidates = []
    if "SWAZURE_CONFIG_DIR" in os.environ:
        candidates.append(Path(os.environ["SWAZURE_CONFIG_DIR"]))
    # A source checkout or editable install, then an installed share/ folder: the
    # package's own install prefix (colcon's install space), then the interpreter's.
    here = Path(__file__).resolve()
    candidates.append(here.parents[2] / "config")
    if len(here.parents) > 5:  # <prefix>/lib/pythonX.Y/site-packages/swazure_ros/core/
        candidates.append(here.parents[5] / "share" / "swazure_ros" / "config")
    candidates.append(Path(sys.prefix) / "share" / "swazure_ros" / "config")
    for candidate in candidates:
        if (candidate / "sensor.yaml").is_file():
            return candidate
    raise SensorError("cannot find the configuration folder with sensor.yaml")


def _meminfo(field: str) -> int | None:
    """A field of /proc/meminfo, bytes; None where there is none (not Linux)."""
    try:
        with open("/proc/meminfo") as meminfo:
            for line in meminfo:
                if line.startswith(f"{field}:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return None


def total_memory() -> int:
    """Memory this machine has, bytes (MemTotal)."""
    total = _meminfo("MemTotal")
    return total if total is not None else os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def available_memory() -> int:
    """Memory free for a run of this process, bytes.

    The machine's free memory (MemAvailable, else all of it), but no more than
    the address space this process may still take under its limit (``ulimit
    -v``, RLIMIT_AS): past it an allocation fails, and a BLAS or a compiled
    kernel that meets the failure ends the process with SIGSEGV rather than
    an error.
    """
    available = _meminfo("MemAvailable")
    free = available if available is not None else total_memory()
    limit, _ = resource.getrlimit(resource.RLIMIT_AS)
    if limit != resource.RLIM_INFINITY:
        free = min(free, max(0, limit - _address_space()))
    return free


def _address_space() -> int:
    """The address space this process takes now, bytes (VmSize; 0 where unknown)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError):
        pass
    return 0
