"""The one way a test waits: until a condition holds, with a deadline that allows for load."""

from __future__ import annotations

import time
from collections.abc import Callable

#: The deadline of a wait for what takes seconds on a quiet machine. Two runs of the
#: suite side by side on two cores, beside other work, stretch seconds into minutes;
#: a wait ends as soon as its condition holds, so a long deadline costs a passing test
#: nothing and only makes a failing one slower to say so.
PATIENCE = 300.0


def wait_until(
    condition: Callable[[], object],
    timeout: float = PATIENCE,
    step: Callable[[], object] | None = None,
) -> bool:
    """Call ``step()`` until ``condition()`` holds or ``timeout`` s pass; whether it holds.

    ``step`` is what makes progress meanwhile (spin an executor, publish again);
    without one the test sleeps 0.05 s between looks. The condition is looked at
    once more after the deadline, so a wait never fails on what just arrived.
    """
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        if step is None:
            time.sleep(0.05)
        else:
            step()
    return bool(condition())
