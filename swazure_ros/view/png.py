"""Figures written as PNG files, atomically, at one resolution for the whole project."""

from __future__ import annotations

from pathlib import Path

from matplotlib.figure import Figure

from ..files.atomic import atomic_write

#: Dots per inch of every PNG the project writes.
DPI = 120


def save(figure: Figure, path: Path) -> Path:
    """Write ``figure`` as PNG to ``path`` atomically; return the path."""
    atomic_write(path, lambda tmp: figure.savefig(tmp, format="png", dpi=DPI))
    return path
