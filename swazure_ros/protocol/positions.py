"""Where each FLS of a swarm is, as its coordinator knows it: the world's revisions as heard.

Every FLS starts at its assigned point (the display's shape, common
knowledge); each world revision heard, when it is the newest, moves the
FLSs it names. Under --no-key it is what an FLS's report is checked against
(:func:`~.plausible.implausible_estimates`).
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ..core.arrays import FloatArray, IntArray
from ..core.geometry import Swarm


class Positions:
    """Where each FLS is: its assigned point, then the world's revisions as heard.

    Under --no-key, what a report is checked against.
    """

    def __init__(self, swarm: Swarm, fls_ids: Iterable[int]) -> None:
        self.ids = np.array(sorted(fls_ids), dtype=np.int64)
        order = np.argsort(swarm.cloud_index)
        self._points = np.array(swarm.points[order], dtype=np.float64)
        self.revision = 0  # the newest world revision seen
        self.asked_revision = 0  # the revision our last group of moves makes

    def takes(self, revision: int) -> bool:
        """Whether world revision ``revision`` is the newest heard (or as new): its positions
        are taken, an older one's are not."""
        return revision >= self.revision

    def hear(self, revision: int, ids: IntArray, points: FloatArray) -> None:
        """World revision ``revision``: FLSs ``ids`` (M,) at ``points`` (M, 3), cm; taken
        when it is the newest (:meth:`takes`)."""
        if self.takes(revision):
            self._points[np.searchsorted(self.ids, ids)] = points
        self.revision = max(self.revision, revision)

    def where(self, ids: IntArray) -> FloatArray:
        """Where FLSs ``ids`` (M,) are, (M, 3), cm, by the newest world revision heard."""
        return np.asarray(self._points[np.searchsorted(self.ids, ids)])
