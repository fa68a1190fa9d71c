"""Writing files whole: a result is at its path complete, or not at all.

Every file is written to a temporary name in the same folder and renamed into
place, so a killed run never leaves a half-written result (:func:`atomic_write`,
:func:`atomic_output` for a writer that runs as long as a block,
:func:`atomic_folder` for a folder). JSON is written without NaN or infinities,
which it has no numbers for (:func:`write_json`).
"""

from __future__ import annotations

import contextlib
import glob
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..core.errors import OutputError
from ..core.summary import Document


def atomic_write(path: Path, write: Callable[[Path], object]) -> None:
    """Call ``write(temporary_path)`` and put the result at ``path`` in one rename.

    The temporary file is hidden beside ``path`` and stamped with the writer's
    pid; one left by a killed writer is removed by the next write of ``path``.
    Any failure is an :class:`OutputError`.
    """
    with atomic_output(path) as temporary:
        write(temporary)


@contextmanager
def atomic_folder(path: Path) -> Iterator[Path]:
    """A hidden folder beside ``path`` to fill; it becomes ``path`` when the block ends well.

    ``path`` must not exist (as ``ros2 bag record -o`` refuses one); nothing is
    left there when the block raises, and a process that dies leaves only the
    hidden folder.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        folder = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
    except OSError as err:
        raise OutputError(f"{path}: cannot write ({err.strerror or err})") from err
    try:
        yield folder
        os.rename(folder, path)
    except OSError as err:
        shutil.rmtree(folder, ignore_errors=True)
        raise OutputError(f"{path}: cannot write ({err.strerror or err})") from err
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


@contextmanager
def atomic_output(path: Path) -> Iterator[Path]:
    """A path to write ``path``'s content to; it becomes ``path`` when the block ends well.

    :func:`atomic_write` for a writer that runs as long as the block (a
    recording): nothing is left at ``path`` when the block raises, and what a
    killed writer leaves is removed by the next write of ``path``.
    """
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(path)
        # In the target's folder, so that the rename stays on one file system.
        handle, name = tempfile.mkstemp(
            prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp", dir=path.parent
        )
        temporary = Path(name)
        try:
            # mkstemp makes the file private; give it the mode a plain open() would,
            # before the writer, which may make it private again (a key file).
            try:
                os.fchmod(handle, 0o666 & ~_umask())
            finally:
                os.close(handle)
            yield temporary
            os.replace(temporary, path)
        except BaseException:
            temporary.unlink(missing_ok=True)
            raise
    except OSError as err:
        raise OutputError(f"{path}: cannot write ({err.strerror or err})") from err


def _umask() -> int:
    """The process's umask, read without setting it (``os.umask`` sets it, for every thread)."""
    with contextlib.suppress(OSError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    return 0o022


def _remove_stale(path: Path) -> None:
    """Remove the temporaries of ``path`` whose writers were killed (their pid is gone)."""
    for stale in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        pid = stale.name[len(path.name) + 2 :].partition(".")[0]
        if pid.isdigit() and not _alive(int(pid)):
            stale.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def finite_json(value: Any) -> Any:
    """``value`` with every NaN or infinite float as None: JSON has no such numbers."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {key: finite_json(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [finite_json(item) for item in value]
    return value


def write_json(path: Path, document: Document) -> None:
    """Write ``document`` as indented JSON (non-finite numbers as null), atomically."""
    text = json.dumps(finite_json(document), indent=2, allow_nan=False) + "\n"
    atomic_write(path, lambda tmp: tmp.write_text(text))
