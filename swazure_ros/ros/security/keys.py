"""A swarm's key on disk: 32 random bytes as 64 hexadecimal digits (no rclpy here)."""

from __future__ import annotations

import os
import secrets
import stat
import sys
from pathlib import Path

from ...core.errors import SwazureError
from ...files.atomic import atomic_write
from ...files.reading import read_bytes

#: Bytes of a key.
KEY_BYTES = 32
#: Bytes a key file may hold: its digits, a line end, some blanks.
KEY_FILE_BYTES = 1024
#: The environment variable that names a swarm's key file (beside --key-file, key_file).
KEY_FILE_VARIABLE = "SWAZURE_SWARM_KEY_FILE"


def new_key() -> bytes:
    """A fresh random key for one swarm."""
    return secrets.token_bytes(KEY_BYTES)


def read_key(path: str | Path) -> bytes:
    """The key in file ``path``; SwazureError in one line if it holds none.

    A key file that others than its owner may read or write is taken, with
    one line of warning on stderr (:func:`unprotected`): legal, but whoever
    reads it can sign as the swarm.
    """
    path = Path(path)
    # Regular and small: a FIFO or /dev/zero named as a key file would block or fill memory.
    data = read_bytes(path, "swarm key", KEY_FILE_BYTES, SwazureError)
    try:
        text = data.decode("ascii").strip()
    except UnicodeDecodeError as err:
        raise SwazureError(f"{path}: cannot read the swarm key (not text)") from err
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        raise SwazureError(f"{path}: a swarm key is {2 * KEY_BYTES} hexadecimal digits")
    warning = unprotected(path)
    if warning is not None:
        print(warning, file=sys.stderr, flush=True)
    return key


def unprotected(path: Path) -> str | None:
    """The warning for key file ``path`` if others than its owner may read or write it
    (any group or other permission, as ssh judges a private key file); None if not."""
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
    except OSError:
        return None  # read a moment ago: gone since, nothing to warn of
    if not mode & 0o077:
        return None
    return (
        f"warning: swarm key file {path} is open to others than its owner (mode {mode:04o}): "
        f"whoever reads it can sign as the swarm; taken anyway (chmod 600 {path})"
    )


def write_key(path: Path, key: bytes) -> None:
    """Write ``key`` to ``path`` atomically, readable by its owner only."""

    def write(temporary: Path) -> None:
        temporary.write_text(key.hex() + "\n", encoding="ascii")
        os.chmod(temporary, 0o600)

    atomic_write(path, write)


def key_from(key_file: str) -> bytes | None:
    """The key in ``key_file``, else in the file $SWAZURE_SWARM_KEY_FILE names; None if neither."""
    path = key_file or os.environ.get(KEY_FILE_VARIABLE, "")
    return read_key(path) if path else None
