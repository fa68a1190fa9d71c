"""Progress a command shows on stderr while it works."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tqdm import tqdm


class CreationBar:
    """A tqdm bar of nodes created across every process, on stderr."""

    def __init__(self, quiet: bool) -> None:
        self._quiet = quiet
        self._bar: tqdm[None] | None = None  # made at the first count: it knows the total

    def __call__(self, created: int, total: int) -> None:
        if self._quiet:
            return
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc="FLS nodes", unit="node", file=sys.stderr)
        self._bar.update(created - self._bar.n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
