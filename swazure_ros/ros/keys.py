"""A swarm's key on disk: 32 random bytes as 64 hexadecimal digits (no rclpy here)."""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from ..core.errors import SwazureError
from ..core.results import atomic_write

#: Bytes of a key.
KEY_BYTES = 32
#: The environment variable that names a swarm's key file (beside --key-file, key_file).
KEY_FILE_VARIABLE = "SWAZURE_SWARM_KEY_FILE"


def new_key() -> bytes:
    """A fresh random key for one swarm."""
    return secrets.token_bytes(KEY_BYTES)


def read_key(path: str | Path) -> bytes:
    """The key in file ``path``; SwazureError in one line if it holds none."""
    path = Path(path)
    try:
        text = path.read_bytes()[: 4 * KEY_BYTES].decode("ascii").strip()
    except (OSError, UnicodeDecodeError) as err:
        reason = getattr(err, "strerror", None) or "not text"
        raise SwazureError(f"{path}: cannot read the swarm key ({reason})") from err
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
