"""How a process of the swarm (``ros.plumbing.process.run_process``) ends when it is asked to."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from swazure_ros.ros.plumbing.process import COLLECT_AFTER, SWARM_STOP_VARIABLE

from ...waits import PATIENCE, wait_until
from ..helpers import long_lease_environment, with_shared_memory

#: A process whose one node is stuck in a callback: it cannot end when asked.
STUCK = """
import sys, time
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode

process.STOP_LIMIT = 2.0  # the watchdog's limit, short for the test


def build(context, values):
    node = SwarmNode("stuck", context=context)

    def stuck_in_a_callback():
        if "--main-blocks-stops" in sys.argv:
            # As a main thread stuck in C may be: the signals go to another thread.
            process.signal.pthread_sigmask(process.signal.SIG_BLOCK, process.STOP_SIGNALS)
        print("stuck", flush=True)
        time.sleep(3600)

    node.create_timer(0.1, stuck_in_a_callback)
    return [node]


sys.exit(process.run_process(build, []))
"""


def run_script(source: str) -> subprocess.CompletedProcess[str]:
    """Run ``source`` in a Python process of its own, its shared memory named to it."""
    return subprocess.run(
        [sys.executable, "-c", source], capture_output=True, text=True,
        timeout=PATIENCE, env=with_shared_memory(os.environ),
    )  # fmt: skip


def _block_stops() -> None:
    signal.pthread_sigmask(signal.SIG_BLOCK, (signal.SIGINT, signal.SIGTERM))


@pytest.mark.parametrize(
    "how",
    ["plain", "main-blocks-stops", "started-with-stops-blocked"],
)
def test_a_process_that_hangs_when_asked_to_stop_prints_where_and_exits_1(domain, how):
    # Its SIGINT arms the watchdog whichever thread the kernel hands it to, and also
    # when the process started with the stop signals blocked (a parent's mask is inherited).
    process = subprocess.Popen(
        [sys.executable, "-c", STUCK, f"--{how}"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_block_stops if how == "started-with-stops-blocked" else None,
    )
    try:
        assert process.stdout is not None
        assert process.stdout.readline().strip() == "stuck"
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=PATIENCE)
    finally:
        process.kill()
    assert process.returncode == 1, err
    # faulthandler's dump: every thread's stack, the stuck callback among the frames.
    assert "Timeout" in err and "stuck_in_a_callback" in err, err


#: A process whose teardown hangs: a C exit handler that never returns, as Fast DDS's
#: did in a deadlock of its own threads (eProsima/Fast-DDS#6502).
HANGING_TEARDOWN = """
import ctypes
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.shared_memory import own_segments

node = SwarmNode("hanging", context=process.init_context())
libc = ctypes.CDLL(None)
# pause(): a C exit handler that never returns, run before Fast DDS's own teardown.
libc["__cxa_atexit"](ctypes.cast(libc.pause, ctypes.c_void_p), None, None)
print(*own_segments(), flush=True)
process.exit_process(3, limit=1.0)
"""


def test_a_teardown_that_hangs_is_ended_by_its_watchdog_saying_so():
    # The hanging handler never returns: only the watchdog can end the process, and it
    # removes the process's own shared-memory segment, which the teardown never did.
    process = run_script(HANGING_TEARDOWN)
    assert process.returncode == -signal.SIGKILL, process.stderr
    assert "the DDS teardown did not end in 1 s" in process.stderr, process.stderr
    segments = [Path(name) for name in process.stdout.split()]
    assert segments and not any(path.exists() for path in segments), segments


#: A process whose exit works for 3 s (an exit handler at work, as a teardown slowed by a
#: busy machine), with a watchdog limit of 1 s.
SLOW_TEARDOWN = """
import atexit, time
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode

node = SwarmNode("slow", context=process.init_context())

def working():
    end = time.monotonic() + 3.0
    while time.monotonic() < end:
        pass

atexit.register(working)
process.exit_process(3, limit=1.0)
"""


def test_a_teardown_that_is_slow_but_working_is_not_taken_for_dead():
    process = run_script(SLOW_TEARDOWN)
    assert process.returncode == 3, process.stderr
    assert "did not end" not in process.stderr, process.stderr


#: A process that leaves without DDS's teardown, as one stopped with its whole swarm.
QUIET = """
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.ros.plumbing.shared_memory import own_segments

node = SwarmNode("quiet", context=process.init_context())
print(*own_segments(), flush=True)
process.leave_quietly(0)
"""


def test_a_process_that_leaves_quietly_leaves_no_shared_memory_of_its_own():
    process = run_script(QUIET)
    assert process.returncode == 0, process.stderr
    # Its segment and the segment's lock, made by Fast DDS for its participant.
    segments = [Path(name) for name in process.stdout.split()]
    assert len(segments) == 2 and segments[1].name == segments[0].name + "_el", segments
    assert not any(path.exists() for path in segments), segments


#: A process of many nodes that ends by exit_process, with its exit handlers.
ENDING = """
import atexit, sys, time
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode
from std_msgs.msg import String

context = process.init_context()
nodes = [SwarmNode(f"ending_{index}", context=context) for index in range(200)]
for node in nodes:
    for topic in range(5):
        node.create_publisher(String, f"topic_{topic}", 10)
atexit.register(lambda: print("exit handler ran", flush=True))
print("up", flush=True)
sys.stdin.readline()
process.exit_process(3)
"""


def test_a_process_ended_by_exit_process_tells_its_peers_it_left_and_exits_with_its_code(
    context, tmp_path
):
    # Its nodes are not destroyed one by one: Fast DDS's teardown deletes its participant
    # whole and tells its peers (the probe here). Its lease is an hour: a probe that waited
    # for the lease would still see its nodes when the wait below gives up.
    environment = long_lease_environment(
        tmp_path, dict(os.environ, ROS_DOMAIN_ID=str(context.get_domain_id()))
    )
    ending = subprocess.Popen(
        [sys.executable, "-c", ENDING], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        text=True, env=environment,
    )  # fmt: skip
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)

    def ours() -> int:
        return sum(name.startswith("ending_") for name, _ in probe.get_node_names_and_namespaces())

    try:
        assert ending.stdout.readline().strip() == "up"
        wait_until(lambda: ours() == 200, PATIENCE, lambda: executor.spin_once(timeout_sec=0.1))
        assert ours() == 200
        out, _ = ending.communicate("stop\n", timeout=PATIENCE)
        wait_until(lambda: ours() == 0, PATIENCE, lambda: executor.spin_once(timeout_sec=0.1))
        left = ours()
    finally:
        if ending.poll() is None:
            ending.kill()
        executor.shutdown()
        probe.destroy_node()
    assert ending.returncode == 3 and "exit handler ran" in out, out
    assert left == 0, left


#: A process of the swarm with one node, as the fls, world and coordinator programs are.
LEAVING = """
import sys
from swazure_ros.ros.plumbing import process
from swazure_ros.ros.plumbing.node import SwarmNode


def build(context, values):
    return [SwarmNode("leaving", context=context)]


sys.exit(process.run_process(build, []))
"""


@pytest.mark.parametrize(
    ("launched", "signals", "told"),
    [
        # Ctrl-C of `ros2 launch` without a terminal: the group's SIGINT, then launch's own.
        (True, (signal.SIGINT, signal.SIGINT), False),
        (True, (signal.SIGTERM,), True),  # one process of a launched swarm stopped alone
        (False, (signal.SIGINT,), True),  # `ros2 run`'s Ctrl-C: this process alone
    ],
    ids=["launched-sigint", "launched-sigterm", "alone-sigint"],
)
def test_a_process_stopped_with_its_swarm_leaves_quietly_and_one_stopped_alone_tells_its_peers(
    context, tmp_path, launched, signals, told
):
    # A SIGINT to a process its launcher started (SWARM_STOP_VARIABLE) stops the whole
    # swarm: nobody is left to tell, and telling is what deadlocks Fast DDS. Its lease is an
    # hour, so that a peer still listing it after its end was not told, and one listing it
    # no more was.
    environment = long_lease_environment(
        tmp_path, dict(os.environ, ROS_DOMAIN_ID=str(context.get_domain_id()))
    )
    if launched:
        environment[SWARM_STOP_VARIABLE] = "1"
    leaving = subprocess.Popen(
        [sys.executable, "-c", LEAVING], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, env=environment,
    )  # fmt: skip
    probe = Node("probe", context=context, start_parameter_services=False, enable_rosout=False)

    def listed() -> bool:
        return ("leaving", "/") in probe.get_node_names_and_namespaces()

    try:
        # Its handlers are in place before its node is made.
        assert wait_until(listed, PATIENCE)
        for signum in signals:
            leaving.send_signal(signum)
        _, err = leaving.communicate(timeout=PATIENCE)
        # Told, a peer drops it within a second, longer on a busy machine: it is waited
        # for. Not told, the peer lists it for the hour's lease: 10 s of it are looked at
        # (a process that told would have been dropped by then unless the machine is very
        # busy, when this case could pass where it should fail, never the other way).
        gone = wait_until(lambda: not listed(), PATIENCE if told else 10)
        # A swarm started again: its participants are new, and never hear of the old one.
        afterwards = seen_by_a_new_participant(context.get_domain_id(), "leaving")
    finally:
        if leaving.poll() is None:
            leaving.kill()
        probe.destroy_node()
    assert leaving.returncode == 0, err
    assert "did not end in" not in err and "Traceback" not in err, err
    assert gone == told
    assert not afterwards


def seen_by_a_new_participant(domain: int, name: str) -> bool:
    """Whether a participant made now lists node ``name`` once it has heard of the living
    (the test's probe) and for 10 s after."""
    from ..conftest import make_context

    context = make_context(domain)
    node = Node("newcomer", context=context, start_parameter_services=False, enable_rosout=False)
    try:

        def listed(wanted: str) -> bool:
            return (wanted, "/") in node.get_node_names_and_namespaces()

        assert wait_until(lambda: listed("probe"), PATIENCE)
        return wait_until(lambda: listed(name), 10)
    finally:
        node.destroy_node()
        context.try_shutdown()


#: A process that starts ROS as every swarm process does, and says how its collector runs.
COLLECTOR = """
import gc
from swazure_ros.ros.plumbing import process
before = gc.get_threshold()
context = process.init_context()
print(*before, *gc.get_threshold(), flush=True)
process.leave_quietly(0)
"""


def test_a_swarm_process_collects_its_youngest_objects_rarely():
    process = run_script(COLLECTOR)
    assert process.returncode == 0, process.stderr
    young, older, oldest, *after = (int(value) for value in process.stdout.split())
    assert young == 700  # CPython's own
    assert after == [COLLECT_AFTER, older, oldest]


#: A process that counts its SIGCONTs, then says at each line it reads whether it went on
#: after a stop since it last looked (with threads of its own, as DDS's).
CONTINUED = """
import sys, threading
from swazure_ros.ros.plumbing import process
continues = process.catch_continues()
threading.Thread(target=threading.Event().wait, daemon=True).start()
print(continues.went_on(), flush=True)
for line in sys.stdin:
    print(continues.went_on(), flush=True)
"""


def test_a_process_tells_it_was_stopped_and_went_on_once_per_stop():
    """kill -STOP, kill -CONT: the process goes on, and its next look (only that one) says it
    went on after a stop; a stop is then not taken for starving, however long its threads
    wait for a CPU afterwards (protocol.pulse)."""
    with subprocess.Popen(
        [sys.executable, "-c", CONTINUED], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        text=True,
    ) as child:  # fmt: skip
        assert child.stdin is not None and child.stdout is not None
        try:
            assert child.stdout.readline().strip() == "False"
            os.kill(child.pid, signal.SIGSTOP)
            # Stopped in earnest before it goes on, as after a stop of seconds.
            assert wait_until(lambda: process_state(child.pid) == "T", PATIENCE)
            os.kill(child.pid, signal.SIGCONT)
            looks = []

            def look() -> str:
                child.stdin.write("look\n")
                child.stdin.flush()
                looks.append(child.stdout.readline().strip())
                return looks[-1]

            # The count is the main thread's to make, at its next bytecode; where the kernel
            # handed the signal to another thread first, a look may come before it
            # (process.catch_continues says so), so a busy machine gets a few looks.
            assert wait_until(lambda: look() == "True", PATIENCE), looks
            assert look() == "False"
            assert looks.count("True") == 1, looks
        finally:
            child.kill()


def process_state(pid: int) -> str:
    """Process ``pid``'s state letter (Linux: /proc; "T": stopped)."""
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
