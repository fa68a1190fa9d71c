"""A swarm's key on disk: 32 random bytes as 64 hexadecimal digits (no rclpy here)."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from ...core.errors import SwazureError
from ...files.reading import read_bytes
from ...files.results import atomic_write

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
    """The key in file ``path``; SwazureError in one line if it holds none."""
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
    return key


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
