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


#: The units of a stage whose end is not a count of things: its share done, in hundredths.
HUNDREDTHS = 100


class Share:
    """A stage of :data:`HUNDREDTHS` units advanced to a share of its way, never back.

    For work whose end is a tolerance, not a count (an iterative solve): the
    caller says how far it has come (:meth:`reach`), and the stage advances
    by the hundredths gained since.
    """

    def __init__(self, progress: Progress, stage: str) -> None:
        self._progress, self._shown = progress, 0
        progress.start(stage, HUNDREDTHS)

    def reach(self, share: float) -> None:
        """Advance to ``share`` (0 to 1) of the way; a share below the last shown does nothing."""
        units = min(HUNDREDTHS, int(HUNDREDTHS * max(share, 0.0)))
        if units > self._shown:
            self._progress.advance(units - self._shown)
            self._shown = units


class Started:
    """``progress`` that remembers whether a stage was started through it (:attr:`started`):
    whoever lent it knows then that its own stage was put aside."""

    def __init__(self, progress: Progress) -> None:
        self._progress, self.started = progress, False

    def start(self, stage: str, total: int) -> None:
        self.started = True
        self._progress.start(stage, total)

    def advance(self, units: int) -> None:
        self._progress.advance(units)
