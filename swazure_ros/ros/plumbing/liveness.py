"""Which FLS nodes have left the ROS graph: the one liveness check of every process."""

from __future__ import annotations

import time

from rclpy.node import Node

from ...protocol.rounds import Absences
from .names import fls_id_of

#: The share of its thread's time a process may spend looking at the graph. A look lists
#: every node of the graph: at torus:30000 over 4 processes one took about 27 ms, and
#: the launcher, which looks for its host and for its coordinator, spent 10 % of a core
#: on them at two looks a second each (BENCHMARKS.md). A large swarm is looked at less
#: often; a small one, whose looks take well under a millisecond, as often as asked.
LOOK_SHARE = 0.02


def look_interval(look_seconds: float, grace: float) -> float:
    """The least time between two looks at the graph, s, after one that took ``look_seconds``
    of its thread's CPU: within :data:`LOOK_SHARE` of the thread, and never longer than
    the ``grace`` an absence must last, so that an FLS gone is seen within the grace and
    two such intervals (three times the grace at most; with looks half a second apart it
    was the grace and a second).

    Examples
    --------
    >>> from swazure_ros.ros.plumbing.liveness import look_interval
    >>> look_interval(0.0005, 2.0), look_interval(0.03, 2.0), look_interval(0.1, 2.0)
    (0.025, 1.5, 2.0)
    """
    return min(look_seconds / LOOK_SHARE, grace)


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
        self._next_look = 0.0  # monotonic s: when a look is due again (:meth:`due`)

    def due(self) -> bool:
        """Whether a look now keeps the looks within :data:`LOOK_SHARE` of this thread
        (:func:`look_interval`): a periodic looker skips the look when not."""
        return time.monotonic() >= self._next_look

    def look(self, gone: set[int], now: float | None = None) -> set[int]:
        """The FLSs newly gone (not already in ``gone``), from the graph as it is now.

        Sets :attr:`back`: the FLSs of ``gone`` that have been on it again for ``grace`` s.
        ``now``: the time the grace runs on, s (monotonic by default). A looker
        whose process stalls gives a clock that leaves its stalls out (the
        coordinator's ``StallClock``): an FLS is not counted absent while the
        looker could not look.
        """
        # CPU time, not wall: a look that waited for a busy core cost the process nothing.
        began, spent = time.monotonic(), time.thread_time()
        self.nodes = self._node.get_node_names_and_namespaces()
        present = {
            fls_id
            for name, where in self.nodes
            if where == self.namespace and (fls_id := fls_id_of(name)) is not None
        }
        self._next_look = began + look_interval(time.thread_time() - spent, self._absent.grace)
        self.seen |= present
        now = time.monotonic() if now is None else now
        self.back = self._present.gone(present & gone, now)
        return self._absent.gone(self.seen - present - gone, now)
