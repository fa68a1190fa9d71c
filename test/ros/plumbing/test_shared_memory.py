"""A process's own Fast DDS shared-memory segments: found by the locks it holds, removed."""

from __future__ import annotations

import os
import subprocess
import sys

from swazure_ros.ros.plumbing.shared_memory import SHARED_MEMORY, kill, own_segments, remove

from ..helpers import with_shared_memory


def test_a_process_holding_a_segment_lock_owns_that_segment_and_no_other(tmp_path):
    # Fast DDS's names, in the folder it uses; this test's own files, removed after.
    name = f"fastrtps_{os.getpid():016x}"
    segment, lock = SHARED_MEMORY / name, SHARED_MEMORY / f"{name}_el"
    port_lock = SHARED_MEMORY / f"fastrtps_port{os.getpid()}_el"  # a port's: shared
    for path in (segment, lock, port_lock):
        path.write_bytes(b"")
    try:
        assert segment not in own_segments()
        with lock.open("rb"), port_lock.open("rb"):
            assert {segment, lock} <= set(own_segments())
            assert port_lock not in own_segments()
        assert segment not in own_segments()
        remove([segment, lock])
        assert not segment.exists() and not lock.exists()
        remove([segment, lock])  # gone already: nothing to do
    finally:
        for path in (segment, lock, port_lock):
            path.unlink(missing_ok=True)


def test_a_process_that_is_not_there_owns_nothing():
    assert own_segments(2**22 + 7) == []


#: A process with a DDS participant, over shared memory too, that waits to be killed.
WAITING = """
import time
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.shared_memory import own_segments

node = SwarmNode("waiting", context=process.init_context())
print(*own_segments(), flush=True)
time.sleep(600)
"""


def test_a_process_killed_by_kill_leaves_no_segment_of_its_own():
    environment = with_shared_memory(dict(os.environ))
    with subprocess.Popen(
        [sys.executable, "-c", WAITING], stdout=subprocess.PIPE, text=True, env=environment
    ) as waiting:
        try:
            assert waiting.stdout is not None
            segments = [SHARED_MEMORY / name for name in waiting.stdout.readline().split()]
            assert len(segments) == 2 and all(path.exists() for path in segments), segments
        finally:
            kill(waiting)
    assert waiting.returncode == -9
    assert not any(path.exists() for path in segments), segments
