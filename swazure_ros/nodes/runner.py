"""Running the coordinator beside the FLS nodes: its own executor in its own thread.

The FLS nodes spin on an events executor, which cannot suspend a callback; the
coordinator awaits inside callbacks (a round, a service answer), so it gets a
stock single-threaded executor in a thread of its own.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from .coordinator import Coordinator

T = TypeVar("T")


class CoordinatorThread:
    """Spins a :class:`Coordinator` in a daemon thread until :meth:`close`."""

    def __init__(self, coordinator: Coordinator) -> None:
        self.coordinator = coordinator
        self.executor = SingleThreadedExecutor(context=coordinator.context)
        self.executor.add_node(coordinator)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name="coordinator", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        while not self._stop.is_set():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except ExternalShutdownException:
                return
            except Exception:
                # A failed task re-raises here, but run() is the one to report it: the
                # thread must live on to complete the task's done callback.
                continue

    def run(
        self,
        coroutine: Coroutine[Any, Any, T],
        spin: Callable[[float], None],
        timeout: float | None = None,
    ) -> T:
        """Run ``coroutine`` on the coordinator's executor, calling ``spin(seconds)`` meanwhile.

        ``spin`` serves the FLS nodes of this thread's executor while the task runs.
        """
        done = threading.Event()
        task = self.executor.create_task(coroutine)
        task.add_done_callback(lambda _: done.set())
        deadline = None if timeout is None else time.monotonic() + timeout
        while not done.is_set():
            if deadline is not None and time.monotonic() > deadline:
                task.cancel()
                raise TimeoutError(f"coordinator task not done after {timeout} s")
            spin(0.02)
        if task.exception() is not None:
            raise task.exception()  # type: ignore[misc]
        return task.result()  # type: ignore[return-value]

    def close(self) -> None:
        """Stop spinning and destroy the coordinator."""
        self._stop.set()
        self._thread.join(timeout=5)
        self.executor.remove_node(self.coordinator)
        self.coordinator.destroy_node()
        self.executor.shutdown()
