"""How a long stage tells its progress: the :class:`Progress` protocol, and :data:`SILENT`.

The engine's stages (line of sight, the path searches, a fit) ``start`` a
stage of so many units and ``advance`` through it; a progress bar (the
CLI's) or nothing (:data:`SILENT`) listens.
"""

from __future__ import annotations

from typing import Protocol


class Progress(Protocol):
    """Receives progress of long stages: ``start`` a stage of ``total`` units, then ``advance``."""

    def start(self, stage: str, total: int) -> None: ...

    def advance(self, units: int) -> None: ...


class _Silent:
    def start(self, stage: str, total: int) -> None:
        pass

    def advance(self, units: int) -> None:
        pass


#: Progress that shows nothing.
SILENT: Progress = _Silent()
