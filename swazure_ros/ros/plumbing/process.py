"""A process's life: its rclpy context, its nodes spun until it is asked to stop, its end.

A process of a swarm owns one :class:`~rclpy.context.Context`
(:func:`init_context`), never the global one, so that tests and tools can
run several swarms side by side. A program (one FLS, the world, the
coordinator) is :func:`run_process`: its startup arguments read, its nodes
built and spun until SIGINT or SIGTERM. A process ends by
:func:`exit_process` (its DDS participant deleted whole, its peers told at
once) or, stopped with its whole swarm, by :func:`leave_quietly`.
"""

from __future__ import annotations

import contextlib
import faulthandler
import gc
import os
import signal
import socket
import subprocess
import sys
import threading
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import NoReturn

import rclpy

# The context every process owns; app/ names it through this module, not through rclpy.
from rclpy.context import Context as Context
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from ...core.errors import SwazureError
from . import shared_memory
from .parameters import ParameterSpec
from .participants import load_with_swarm_profile
from .startup import StartupValues, check_params_file, program_startup

#: Container objects a process may allocate, net of those freed, before CPython's cyclic
#: collector looks at its youngest objects (CPython's default is 700). A packed process
#: makes and drops thousands of small records a round (offers, their table, the tally);
#: at 700 the collector ran 8,453 times in the dragon's swarm fit, its older passes
#: walking every object the process holds: 3.3 s of 26 s (BENCHMARKS.md, "The fit's
#: rounds made together, and a process's collector"). Reference counting frees nearly
#: all of them; what cycles are left wait a little longer.
COLLECT_AFTER = 10_000


def collect_rarely() -> None:
    """Set this process's cyclic collector to :data:`COLLECT_AFTER` (the older generations'
    thresholds as they are): a process that runs swarm nodes calls it as it starts."""
    _, older, oldest = gc.get_threshold()
    gc.set_threshold(COLLECT_AFTER, older, oldest)


def init_context(domain_id: int | None = None, params_file: str | None = None) -> Context:
    """A fresh rclpy context on ``domain_id``, with a ROS 2 parameter file if given, in a
    process whose collector runs rarely (:func:`collect_rarely`) and whose participant
    loads the swarm's Fast DDS profile unless the user names one (:mod:`.participants`).

    Signals are left to the caller: a swarm stops between spins, not inside a callback.
    """
    collect_rarely()
    args = []
    if params_file is not None:
        # Checked here so that a bad file gives our one line, not rcl's log lines too.
        check_params_file(Path(params_file))
        args = ["--ros-args", "--params-file", params_file]
    load_with_swarm_profile()
    context = Context()
    try:
        rclpy.init(
            args=args,
            context=context,
            domain_id=domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
    except Exception as err:  # rclpy reports a bad parameter file as a bare RCLError
        if params_file is None:
            raise SwazureError(f"cannot start ROS 2 here: {err}") from err
        raise SwazureError(f"{params_file}: not a valid ROS 2 parameter file") from err
    return context


#: Seconds a process's DDS teardown (:func:`exit_process`) may stand still, using no CPU,
#: before its watchdog ends it (SIGKILL, a line in its log): a teardown that works, however
#: slowly on a busy machine, goes on, up to TEARDOWN_CAP times this.
TEARDOWN_LIMIT = 30.0
#: The same for a :func:`run_process` program: one FLS, the world or the coordinator,
#: whose teardown takes about a second.
PROGRAM_TEARDOWN_LIMIT = 5.0
#: A teardown that keeps using CPU is ended at this many times its limit: a deadlock that
#: spins is a deadlock too.
TEARDOWN_CAP = 6
#: Seconds a :func:`run_process` program may take to reach its teardown once asked to
#: end before its watchdog ends it (exit code 1, every thread's stack in its log); with
#: the teardown's limit, under the launcher's grace (app.per_fls.STOP_GRACE), which
#: would kill it without a word.
STOP_LIMIT = 12.0


#: The watchdog of a process's teardown (:func:`exit_process`), a process of its own: it
#: waits for the end of file of a pipe that only the ending process holds open, and ends
#: that process (SIGKILL) once its CPU time has stood still for ``limit`` s (threads that
#: wait on each other: Fast-DDS#6502), or at ``cap`` times ``limit`` in all; then it
#: removes the shared-memory files it is given (the process's own segments, which its
#: teardown never removed). A teardown slowed by a busy machine still uses CPU: it is not
#: taken for dead. Where /proc cannot be read, the CPU time counts as standing still.
TEARDOWN_WATCH = """
import os, select, signal, sys, time
pipe, pid, limit, cap = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])

def cpu_ticks():
    try:
        with open(f"/proc/{pid}/stat") as stat:
            fields = stat.read().rsplit(")", 1)[1].split()
        return int(fields[11]) + int(fields[12])  # utime + stime
    except (OSError, IndexError, ValueError):
        return None

began = still_since = time.monotonic()
last = cpu_ticks()
while not select.select([pipe], [], [], min(0.25, limit))[0]:
    now, ticks = time.monotonic(), cpu_ticks()
    if ticks is not None and ticks != last:
        last, still_since = ticks, now
    if now - still_since >= limit or now - began >= cap * limit:
        waited = f"{limit:g} s without using CPU" if now - still_since >= limit else (
            f"{cap * limit:g} s")
        print(f"the DDS teardown did not end in {waited} (a known Fast DDS deadlock): "
              "leaving without it", file=sys.stderr, flush=True)
        os.kill(pid, signal.SIGKILL)
        for path in sys.argv[5:]:
            try:
                os.unlink(path)
            except OSError:
                pass
        break
"""


def exit_process(code: int, limit: float = TEARDOWN_LIMIT) -> NoReturn:
    """End the process now, leaving its nodes to DDS's own teardown; never returns.

    Destroying nodes one by one costs in proportion to the square of a
    process's endpoints: rmw_fastrtps republishes the participant's whole
    entity list after every endpoint it removes (docs/swarm.md, teardown).
    Python's own exit ends in the C library's exit, whose static teardown of
    Fast DDS deletes the participant whole and tells its peers so at once;
    Python's exit handlers run, but its finalizers, which would destroy each
    node, do not: every object alive now is held by a thread that never
    ends, whose references Python's exit leaves as they are. Call it last,
    when every output is written; it raises SystemExit(``code``).

    Fast DDS 2.14's teardown can deadlock (eProsima/Fast-DDS#6502: its event
    and receive threads, while peers leave at the same time; docs/swarm.md,
    "Stopping"). A process whose teardown has used no CPU for ``limit`` s (or
    still runs at TEARDOWN_CAP times it) is ended by its watchdog
    (TEARDOWN_WATCH: one line, then SIGKILL, then its shared-memory segments
    removed); its peers drop it when its DDS lease runs out.
    """
    # Python's handlers do not run once its exit has begun: a second SIGINT or
    # SIGTERM must end the process then.
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_DFL)
    _flush()
    # Only this process holds the writing end, open to its death: the watchdog's end of file.
    watched, _ = os.pipe()
    subprocess.Popen(
        [sys.executable, "-I", "-S", "-c", TEARDOWN_WATCH, str(watched), str(os.getpid()),
         str(limit), str(TEARDOWN_CAP), *map(str, shared_memory.own_segments())],
        pass_fds=(watched,),
        stdin=subprocess.DEVNULL,
    )  # fmt: skip
    os.close(watched)
    alive = gc.get_objects()
    threading.Thread(target=_hold, args=(alive,), daemon=True).start()
    del alive
    gc.freeze()  # see cli.main.main: Python's last collection would walk them all
    raise SystemExit(code)


def _flush() -> None:
    """Flush Python's standard streams before the process ends."""
    for stream in (sys.stdout, sys.stderr):
        # A reader gone or a stream closed: nothing is left to save.
        with contextlib.suppress(OSError, ValueError):
            stream.flush()


def _hold(alive: list[object]) -> None:
    """Hold ``alive`` until the process ends."""
    threading.Event().wait()


#: Set to "1" by a launcher that starts a whole swarm (``swazure spawn --per-fls``,
#: ``ros2 launch swazure_ros swarm.launch.py mode:=per_fls``) in the environment of each
#: process it starts: a SIGINT to such a process is the whole swarm stopping (the
#: launcher's own, or a terminal's Ctrl-C, which reaches every process of the launch at
#: once), and the process leaves without telling its peers (:func:`leave_quietly`). A
#: SIGTERM stops it alone, and it tells them (:func:`exit_process`).
SWARM_STOP_VARIABLE = "SWAZURE_SWARM_STOPS_ON_SIGINT"


def stops_with_swarm(signum: int) -> bool:
    """Whether signal ``signum`` stops this process with its whole swarm (SWARM_STOP_VARIABLE)."""
    return signum == signal.SIGINT and os.environ.get(SWARM_STOP_VARIABLE) == "1"


def leave_quietly(code: int) -> NoReturn:
    """End the process now with ``code``, without DDS's teardown; never returns.

    For a process whose whole swarm stops with it: no peer needs to hear that
    it leaves, and telling them is what goes wrong. Fast DDS 2.14 deadlocks
    in a process that hears peers leave while it deletes its own participant
    (eProsima/Fast-DDS#6502), and its static teardown has crashed (SIGSEGV)
    after a process's work was done; neither can happen in a process that
    tears nothing down, and the process cannot hang. Participants that live on
    (a `ros2` daemon, a recorder) list its nodes until its lease runs out
    (20 s, docs/swarm.md, "Stopping"); a participant made later never hears of
    them. Call it last, when every output is written: Python's exit handlers
    do not run; its own streams are flushed, and its own shared-memory
    segments removed (:mod:`.shared_memory`), which DDS's teardown would have.
    """
    _flush()
    shared_memory.remove(shared_memory.own_segments())
    os._exit(code)


def seconds_since_start() -> float:
    """Seconds since this process started (Linux: /proc), interpreter start-up included."""
    ticks = os.sysconf("SC_CLK_TCK")
    # Field 22 of /proc/self/stat, after the command name (which may hold spaces).
    started = int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19]) / ticks
    return float(Path("/proc/uptime").read_text().split()[0]) - started


#: The signals that ask a program to end.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def catch_stops(limit: float) -> list[int]:
    """The stop signals this process gets from now on, in a list that fills as they come.

    At the first, a watchdog is armed: a process that has not ended ``limit`` s
    later prints every thread's stack (to its log) and exits 1, so that a stop
    that hangs says where. The watchdog is armed by a thread of its own,
    woken through Python's signal wakeup fd, which the C handler writes from
    whatever thread the kernel hands the signal to: Python's own handler runs
    only in the main thread and only between bytecodes, so a main thread stuck
    in a callback, in C or with the signals blocked would never arm it (a
    stuck process ignored its SIGINT for 300 s on a loaded machine,
    2026-11-29). A mask inherited from the parent that blocks them is lifted:
    a program must hear its stop. Call it from the main thread, before any
    thread of its own is started.
    """
    stop: list[int] = []
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    woken, wake = socket.socketpair()
    wake.setblocking(False)
    signal.set_wakeup_fd(wake.fileno(), warn_on_full_buffer=False)
    for signum in STOP_SIGNALS:
        # Python's C handler then writes the number to the wakeup fd; the watcher acts.
        signal.signal(signum, lambda number, frame: None)

    def watch(woken: socket.socket, wake: socket.socket) -> None:
        # Holds both ends: the writing one must live as long as the wakeup fd names it.
        while numbers := woken.recv(64):
            for number in numbers:
                if number in STOP_SIGNALS:
                    if not stop:
                        faulthandler.dump_traceback_later(limit, exit=True)
                    stop.append(number)

    threading.Thread(target=watch, args=(woken, wake), name="stop-watch", daemon=True).start()
    return stop


class Continues:
    """The times this process went on after a stop (``kill -STOP``, then ``kill -CONT``),
    counted as they come: made by :func:`catch_continues`."""

    def __init__(self) -> None:
        self.count = 0  # SIGCONTs handled so far
        self._seen = 0

    def went_on(self) -> bool:
        """Whether the process went on after a stop since the last call."""
        went_on, self._seen = self.count > self._seen, self.count
        return went_on

    def _on_continue(self, number: int, frame: object) -> None:
        self.count += 1


def catch_continues() -> Continues:
    """Count this process's SIGCONTs from now on, so that its heartbeats can tell a stop
    from starving (``protocol.pulse``).

    Python runs the handler in the main thread at its next bytecode; the kernel
    hands the signal to the main thread first, at its return to user space after
    the stop, so a look that the main thread's executor makes after the process
    went on finds it counted. (A main thread with another signal pending is passed
    over, and a look may then come before the count: that look is judged by the
    threads' wait alone, as before.) A handled SIGCONT still continues the process (the
    kernel acts on it when it is sent). Calls that it interrupts in other threads
    are restarted, as when it was ignored. Call it from the main thread.
    """
    continues = Continues()
    signal.signal(signal.SIGCONT, continues._on_continue)
    signal.siginterrupt(signal.SIGCONT, False)
    return continues


def run_process(
    build: Callable[[Context, StartupValues], list[Node]],
    args: list[str] | None = None,
    *,
    usage: str = "",
    startup: Sequence[ParameterSpec] = (),
) -> NoReturn:
    """Start rclpy, build a process's nodes and spin them until SIGINT or SIGTERM; then exit.

    ``build`` takes the context and the ``startup`` parameters' values, given
    as program arguments (:func:`program_startup`). ``--help`` prints
    ``usage`` and exits 0 without a node. Errors in building
    give one line and exit code 2, never a traceback; any other exception (a
    bug) one line, its stack and exit code 1. Stopped with its whole swarm (a
    SIGINT where SWARM_STOP_VARIABLE is set), the process leaves without
    telling its peers (:func:`leave_quietly`); else it ends with
    :func:`exit_process`: its DDS participant is deleted whole, not endpoint by
    endpoint, and its peers drop its nodes at once (docs/swarm.md, "Stopping").
    """
    values = program_startup(args, usage, startup)
    stop = catch_stops(STOP_LIMIT)
    collect_rarely()
    load_with_swarm_profile()
    context = Context()
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    executor: Executor | None = None
    code = 0
    try:
        nodes = build(context, values)
        executor = EventsExecutor(context=context)
        for node in nodes:
            executor.add_node(node)
        if nodes:
            nodes[0].get_logger().info(f"ready, {seconds_since_start():.2f} s after the start")
        # Not executor.spin(): the EventsExecutor's spin neither returns when a signal
        # shuts the context down nor rests between events (measured: a core each).
        while context.ok() and not stop:
            executor.spin_once(timeout_sec=0.5)
    except SwazureError as err:
        print(f"error: {err}", file=sys.stderr)
        code = 2
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as err:
        # A bug, not bad input: the stack is what a report needs. The process still
        # ends by exit_process, as any other: left to Python's teardown, its nodes
        # would be destroyed endpoint by endpoint (and can deadlock; see below).
        print(f"error: {type(err).__name__}: {err} (a bug; its stack follows)", file=sys.stderr)
        traceback.print_exc()
        code = 1
    if stop and stops_with_swarm(stop[0]):
        # The whole swarm stops: nobody is left to tell (docs/swarm.md, "Stopping").
        leave_quietly(code)
    # The executor first: its shutdown unregisters the callbacks of every
    # subscription, service and timer it tracks, which must be alive then.
    if executor is not None:
        executor.shutdown()
    # Not node by node: each endpoint destroyed makes every peer remove it, and
    # Fast DDS 2.14 can deadlock a peer doing so (eProsima/Fast-DDS#6502).
    exit_process(code, limit=PROGRAM_TEARDOWN_LIMIT)
