"""The node a track run asks and listens through: TrackTarget calls, estimates, FLS progress."""

from __future__ import annotations

from collections.abc import Callable

from rclpy.context import Context
from swazure_interfaces.msg import TrackEstimate, TrackProgress
from swazure_interfaces.srv import TrackTarget

from ...core.arrays import IntArray
from ...core.errors import RunError
from ...core.estimators import TrackingError
from ...core.tracking import ENDED, TIMED_OUT, MotionEstimate
from ...protocol.tracking import TrackProgressReport
from ..convert.tracking import motion_estimate, track_progress_from_message
from ..plumbing.names import (
    ROUND_QOS,
    TRACK_ESTIMATES_TOPIC,
    TRACK_MODEL_CODES,
    TRACK_PROGRESS_TOPIC,
    TRACK_REQUESTS_TOPIC,
    TRACK_SERVICE,
    TRACK_STATE_NAMES,
    node_name,
)
from ..plumbing.node import SwarmNode
from ..security.guard import Guard

#: Spins until a condition holds or a timeout in wall seconds passes; whether it holds.
SpinUntil = Callable[[Callable[[], bool], float], bool]


class SwarmStalledError(RunError):
    """The nodes stopped answering within the wall-clock bound."""


class TrackClient(SwarmNode):
    """Asks a source FLS to track, and collects the source's estimates.

    With a ``guard`` (FLSs in processes of their own), it also hears each
    FLS's ``track_progress`` reports, by which a run knows when all is delivered.
    """

    def __init__(
        self, *, namespace: str, context: Context, ids: IntArray, guard: Guard | None = None
    ) -> None:
        super().__init__("track_client", namespace=namespace, context=context)
        self._namespace = namespace
        self._ids = ids
        #: The source's TrackEstimate messages, in the order they arrived.
        self.estimate_messages: list[TrackEstimate] = []
        #: Each FLS process's last progress report, by FLS id.
        self.progress: dict[int, TrackProgressReport] = {}
        #: Progress reports heard in all: each is news of work done.
        self.reports_heard = 0
        self._estimates = self.create_subscription(
            TrackEstimate, TRACK_ESTIMATES_TOPIC, self.estimate_messages.append, ROUND_QOS
        )
        self._progress = (
            None
            if guard is None
            else guard.subscribe(TrackProgress, TRACK_PROGRESS_TOPIC, self._on_progress, ROUND_QOS)
        )

    def _on_progress(self, message: TrackProgress) -> None:
        # One publisher per FLS, reliable: its reports arrive in order, the last is current.
        report = track_progress_from_message(message, self._ids)
        self.progress[report.fls_id] = report
        self.reports_heard += 1

    def hears(self, count: int) -> bool:
        """Whether ``count`` FLSs' track requests, estimates and progress reach this node."""
        return min(self.matched()) >= count

    def matched(self) -> tuple[int, int, int]:
        """How many FLSs' track request readers, estimate writers and progress writers
        this node sees (progress: as many as estimates where it hears no progress)."""
        requests = self.count_subscribers(f"/{self._namespace}/{TRACK_REQUESTS_TOPIC}")
        estimates = self._estimates.get_publisher_count()
        progress = estimates if self._progress is None else self._progress.get_publisher_count()
        return requests, estimates, progress

    def track(
        self, source: int, target: int, model: str, spin_until: SpinUntil, timeout: float
    ) -> int:
        """Ask FLS ``source`` to track ``target``; the relay it chose, or TrackingError."""
        client = self.create_client(TrackTarget, f"{node_name(source)}/{TRACK_SERVICE}")
        try:
            if not spin_until(client.service_is_ready, timeout):
                raise TrackingError(f"FLS {source}'s {client.srv_name} is not reachable")
            request = TrackTarget.Request(
                source_id=source, target_id=target, model=TRACK_MODEL_CODES[model]
            )
            future = client.call_async(request)
            if not spin_until(future.done, timeout):
                raise SwarmStalledError(f"no answer from {client.srv_name} in {timeout} s")
        finally:
            self.destroy_client(client)
        response = future.result()
        if not response.success:
            raise TrackingError(response.message)
        return int(response.relay_id)

    def ended(self) -> bool:
        """Whether the source's last estimate ended the track (ended, or timed out)."""
        last = self.estimate_messages[-1] if self.estimate_messages else None
        return last is not None and TRACK_STATE_NAMES[last.status] in (ENDED, TIMED_OUT)

    def estimates(self) -> list[MotionEstimate]:
        """The source's estimates in the core's units, in the order they arrived."""
        return [motion_estimate(message) for message in self.estimate_messages]
