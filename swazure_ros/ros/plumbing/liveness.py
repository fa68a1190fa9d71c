"""Which FLS nodes have left the ROS graph: the one liveness check of every process."""

from __future__ import annotations

import time

from rclpy.node import Node

from ...protocol.rounds import Absences
from .names import fls_id_of


class FlsLiveness:
    """The FLS nodes of a namespace that the graph showed once and has not for ``grace`` s.

    Only an FLS once seen can go missing: a swarm's nodes join the graph over
    seconds, remote ones later still. A participant whose lease lapses under
    load drops off the graph for a moment (:class:`~..protocol.rounds.Absences`).
    An FLS gone that the graph shows again for ``grace`` s without a break is
    back (:attr:`back`): a process stopped for a while (``kill -STOP``) and
    resumed, or a link down and up again.
    """

    def __init__(self, node: Node, namespace: str, grace: float) -> None:
        self._node = node
        self.namespace = namespace if namespace.startswith("/") else f"/{namespace}"
        self.seen: set[int] = set()  # FLSs the graph has shown at least once
        self._absent = Absences(grace)
        self._present = Absences(grace)  # the gone that the graph shows again
        #: The FLSs of ``gone`` back on the graph for ``grace`` s, at the last look.
        self.back: set[int] = set()
        self.nodes: list[tuple[str, str]] = []  # the graph's (name, namespace) at the last look

    def look(self, gone: set[int], now: float | None = None) -> set[int]:
        """The FLSs newly gone (not already in ``gone``), from the graph as it is now.

        Sets :attr:`back`: the FLSs of ``gone`` that have been on it again for ``grace`` s.
        ``now``: the time the grace runs on, s (monotonic by default). A looker
        whose process stalls gives a clock that leaves its stalls out (the
        coordinator's ``StallClock``): an FLS is not counted absent while the
        looker could not look.
        """
        self.nodes = self._node.get_node_names_and_namespaces()
        present = {
            fls_id
            for name, where in self.nodes
            if where == self.namespace and (fls_id := fls_id_of(name)) is not None
        }
        self.seen |= present
        now = time.monotonic() if now is None else now
        self.back = self._present.gone(present & gone, now)
        return self._absent.gone(self.seen - present - gone, now)
