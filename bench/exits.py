"""Exits over 100 runs: a swarm of one process per FLS stopped by Ctrl-C, again and again.

The `exits` section of BENCHMARKS.md (`python -m bench --sections exits`), a
subsection of "Under load". Each run brings the trio (config/swarms/trio.yaml)
up, under `ros2 launch swazure_ros swarm.launch.py mode:=per_fls` (from a
terminal, and without one) and under `swazure spawn --per-fls`, waits until
every FLS is on the swarm's radio, sends Ctrl-C's SIGINT to the launcher's
process group, as a terminal does, and records how each process ended: its
exit code or signal, a watchdog's line in its output, the seconds from the
Ctrl-C to its end, and what the run left behind (a key, a temporary folder).
A few more runs keep a participant alive beside the swarm and time how long
its graph still lists the stopped swarm's nodes, and whether a participant
made after the stop lists any.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import pty
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from bench.common import REPO, SWAZURE

#: Runs of each launcher in `make bench`.
RUNS = 100
#: Runs of each launcher that time the stopped swarm's nodes on a live peer's graph.
LINGER_RUNS = 5
TRIO = REPO / "config" / "swarms" / "trio.yaml"
VENV = Path(sys.executable).parents[1]
ROS2 = VENV / "bin" / "ros2"
#: The two launchers a person stops a per-FLS swarm under.
LAUNCH = "ros2 launch"
#: `ros2 launch` without a terminal (a script's, CI's): it sends each process a SIGINT of
#: its own after the group's.
LAUNCH_PIPED = "ros2 launch, no terminal"
SPAWN = "swazure spawn --per-fls"
#: Seconds a bring-up of the trio may take on a loaded machine before the run is given up.
UP_TIMEOUT = 300.0
#: Seconds the bench waits for every process to end after the Ctrl-C; then it kills them.
END_TIMEOUT = 120.0
#: Seconds between two looks at whether a process has ended.
POLL = 0.02
#: What a watchdog prints: the teardown's (process.TEARDOWN_WATCH), a stop's (faulthandler).
WATCHDOG_LINES = ("did not end in", "Timeout (")
#: What an FLS logs once it is on the swarm's radio (ros.programs.fls_program).
JOINED = "on the swarm's radio"
#: How each kind of process is named in the table.
KINDS = {"launch": "ros2 launch itself", "spawn": "swazure spawn (world, coordinator)",
         "world": "world", "coordinator": "coordinator", "fls": "FLS"}  # fmt: skip


@dataclass(frozen=True)
class End:
    """How one process of a run ended after the Ctrl-C."""

    launcher: str
    kind: str  # a key of KINDS
    code: int | None  # negative: killed by that signal; None: still there at END_TIMEOUT
    watchdog: bool  # its output holds a watchdog's line
    seconds: float  # from the Ctrl-C to its end


@dataclass(frozen=True)
class Run:
    """One bring-up and Ctrl-C: how every process ended, and what was left behind."""

    ends: list[End]
    left: list[str]  # paths of the run that were still there once it had ended
    died_lines: int  # lines saying "process has died" (ros2 launch's, for any code but 0)


class Output:
    """A process's output, read line by line as it comes, each with its time."""

    def __init__(self, stream: IO[str]) -> None:
        self.lines: list[tuple[float, str]] = []
        self._reader = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._reader.start()

    def _read(self, stream: IO[str]) -> None:
        for line in stream:
            self.lines.append((time.monotonic(), line.rstrip("\n")))

    def text(self) -> list[str]:
        """Every line so far."""
        return [line for _, line in list(self.lines)]

    def close(self) -> None:
        """Wait for the end of the output (the process has ended)."""
        self._reader.join(timeout=30)


def ended(pid: int) -> bool:
    """Whether process ``pid`` has ended (gone, or a zombie its parent has not reaped)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return True
    return stat.rsplit(")", 1)[1].split()[0] in ("Z", "X")


def end_times(pids: Sequence[int], asked: float, timeout: float = END_TIMEOUT) -> dict[int, float]:
    """Seconds from ``asked`` to each of ``pids``' end; those still there after ``timeout``
    are left out."""
    times: dict[int, float] = {}
    while len(times) < len(pids) and time.monotonic() < asked + timeout:
        for pid in pids:
            if pid not in times and ended(pid):
                times[pid] = time.monotonic() - asked
        time.sleep(POLL)
    return times


def wait_for(condition: Callable[[], bool], timeout: float) -> bool:
    """Whether ``condition()`` held before ``timeout`` s (looked at every 0.2 s)."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.2)
    return True


def environment(domain: int) -> dict[str, str]:
    """The runs' environment: their own domain, on this machine only, the venv's programs."""
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                AMENT_PREFIX_PATH=str(VENV), PYTHONUNBUFFERED="1")  # fmt: skip


def watchdog_said(lines: Sequence[str]) -> bool:
    """Whether ``lines`` hold a watchdog's line."""
    return any(mark in line for line in lines for mark in WATCHDOG_LINES)


@contextlib.contextmanager
def started(
    command: list[str], domain: int, terminal: bool = True
) -> Iterator[tuple[subprocess.Popen[str], Output]]:
    """``command`` in a process group of its own, its stdin a terminal's if ``terminal`` (as a
    person's `ros2 launch` has: interactive), else none; its output merged and read; killed
    if still there."""
    master, side = pty.openpty()
    process = subprocess.Popen(
        command, stdin=side if terminal else subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True, env=environment(domain),
        cwd=tempfile.gettempdir(), start_new_session=True,
    )  # fmt: skip
    os.close(side)
    assert process.stdout is not None
    output = Output(process.stdout)
    try:
        yield process, output
    finally:
        if process.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        output.close()
        process.stdout.close()
        os.close(master)


def ctrl_c(
    leader: int, others: list[int], on_up: Callable[[], None] | None
) -> tuple[float, dict[int, float]]:
    """Ctrl-C to the process group of ``leader`` (after ``on_up``, if any): when it was
    sent, and the seconds from then to the end of ``leader`` and of each of ``others``."""
    if on_up is not None:
        on_up()
    asked = time.monotonic()
    os.killpg(leader, signal.SIGINT)
    return asked, end_times([leader, *others], asked)


def launch_run(
    domain: int, on_up: Callable[[], None] | None = None, terminal: bool = True
) -> Run | None:
    """One `ros2 launch ... mode:=per_fls` of the trio stopped by Ctrl-C, from a terminal or
    not; None if it did not come up. ``on_up`` is called once it is up, before the Ctrl-C."""
    command = [str(ROS2), "launch", "swazure_ros", "swarm.launch.py", f"swarm:={TRIO}",
               "mode:=per_fls"]  # fmt: skip
    launcher = LAUNCH if terminal else LAUNCH_PIPED
    with started(command, domain, terminal) as (launch, output):
        if not wait_for(lambda: sum(JOINED in x for x in output.text()) >= 3, UP_TIMEOUT):
            return None
        # "[INFO] [fls_0-3]: process started with pid [1234]"
        found = (re.search(r"\[INFO\] \[(\w+)-\d+\]: process started with pid \[(\d+)\]", x)
                 for x in output.text())  # fmt: skip
        pids = {int(hit[2]): hit[1] for hit in found if hit}
        keys = {part for pid in pids for part in _arguments(pid) if part.endswith("swarm.key")}
        asked, times = ctrl_c(launch.pid, list(pids), on_up)
    said = [line for at, line in output.lines if at >= asked]
    ends = [End(launcher, "launch", launch.returncode, False, times.get(launch.pid, END_TIMEOUT))]
    for pid, label in pids.items():
        own = [line for line in said if line.startswith(f"[{label}-") or f"[{label}-" in line]
        ends.append(End(launcher, label.split("_")[0], _launch_code(pid, said),
                        watchdog_said(own), times.get(pid, END_TIMEOUT)))  # fmt: skip
    left = [str(Path(key).parent) for key in keys if Path(key).parent.exists()]
    return Run(ends, left, sum("process has died" in line for line in said))


def _arguments(pid: int) -> list[str]:
    """The command line of process ``pid``; empty once it has ended."""
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().split("\0")
    except OSError:
        return []


def _launch_code(pid: int, lines: Sequence[str]) -> int | None:
    """The exit code ros2 launch reported for process ``pid``; None if it reported none."""
    for line in lines:
        if f"process has finished cleanly [pid {pid}]" in line:
            return 0
        died = re.search(rf"process has died \[pid {pid}, exit code (-?\d+)", line)
        if died:
            return int(died[1])
    return None


def piped_launch_run(domain: int, on_up: Callable[[], None] | None = None) -> Run | None:
    """:func:`launch_run` without a terminal."""
    return launch_run(domain, on_up, terminal=False)


def spawn_run(domain: int, on_up: Callable[[], None] | None = None) -> Run | None:
    """One `swazure spawn --per-fls` of the trio stopped by Ctrl-C; None if it did not come
    up. ``on_up`` is called once it is up, before the Ctrl-C."""
    command = [*SWAZURE, "spawn", str(TRIO), "--per-fls", "--quiet"]
    with started(command, domain) as (spawn, output):
        if not wait_for(lambda: any("swarm up:" in x for x in output.text()), UP_TIMEOUT):
            return None
        up = next(x for x in output.text() if "swarm up:" in x)
        logs = Path(up.split("(logs in ", 1)[1].split(")", 1)[0])
        marker = str(logs / "parameters.yaml")
        fls = [pid for pid in _processes() if marker in _arguments(pid)]

        def joined() -> bool:
            said = [_read(logs / f"fls_{fls_id}.log") for fls_id in range(3)]
            return all(JOINED in text for text in said)

        if not wait_for(joined, UP_TIMEOUT):
            return None
        asked, times = ctrl_c(spawn.pid, fls, on_up)
    said = [line for at, line in output.lines if at >= asked]
    codes = _spawn_codes(said)
    ends = [End(SPAWN, "spawn", spawn.returncode, watchdog_said(said),
                times.get(spawn.pid, END_TIMEOUT))]  # fmt: skip
    for fls_id, pid in enumerate(sorted(fls)):
        watched = watchdog_said(_read(logs / f"fls_{fls_id}.log").splitlines())
        ends.append(End(SPAWN, "fls", codes.get(fls_id), watched, times.get(pid, END_TIMEOUT)))
    left = [str(path) for path in (logs / "swarm.key", logs) if path.exists()]
    return Run(ends, left, 0)


def _processes() -> list[int]:
    """Every process id of this machine."""
    return [int(entry.name) for entry in Path("/proc").iterdir() if entry.name.isdigit()]


def _read(path: Path) -> str:
    """The text of ``path``; "" when it is not there (a temporary folder removed)."""
    try:
        return path.read_text(errors="replace")
    except OSError:
        return ""


def _spawn_codes(lines: Sequence[str]) -> dict[int, int | None]:
    """Each FLS's exit code (negative: its signal) as `swazure spawn` reported it."""
    if any("every one cleanly (exit code 0)" in line for line in lines):
        return {fls_id: 0 for fls_id in range(3)}
    if not any("FLS processes stopped" in line for line in lines):
        return {}
    codes: dict[int, int | None] = {fls_id: 0 for fls_id in range(3)}
    for line in lines:
        hit = re.search(r"FLS (\d+)'s process ended with (code|signal) (\d+)", line)
        if hit:
            codes[int(hit[1])] = int(hit[3]) * (-1 if hit[2] == "signal" else 1)
    return codes


def lingering(
    run: Callable[[int, Callable[[], None] | None], Run | None], domain: int
) -> tuple[float, int] | None:
    """How long a participant alive through ``run`` lists the swarm's nodes once every
    process has ended, s; and how many a participant made then lists in 5 s. None if the
    run did not come up."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    def participant() -> tuple[Context, Node]:
        # No spinning: rmw's own thread keeps a participant's graph up to date.
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        node = Node("bench_observer", context=context, enable_rosout=False,
                    start_parameter_services=False)  # fmt: skip
        return context, node

    def swarm(node: Node) -> int:
        return sum(where == "/swarm" for _, where in node.get_node_names_and_namespaces())

    context, alive = participant()
    try:
        seen_up: list[bool] = []

        def heard() -> None:
            # The observer has heard of the swarm (its three FLSs at least) before the Ctrl-C.
            seen_up.append(wait_for(lambda: swarm(alive) >= 3, UP_TIMEOUT))

        if run(domain, heard) is None or not seen_up[0]:
            return None
        stopped = time.monotonic()
        fresh_context, fresh = participant()
        seen, gone = 0, None
        # The newcomer looks for 5 s; the observer until it lists none of the swarm's nodes.
        while time.monotonic() < stopped + END_TIMEOUT and (
            gone is None or time.monotonic() < stopped + 5
        ):
            if time.monotonic() < stopped + 5:
                seen = max(seen, swarm(fresh))
            if gone is None and swarm(alive) == 0:
                gone = time.monotonic() - stopped
            time.sleep(0.05)
        fresh.destroy_node()
        fresh_context.try_shutdown()
        return END_TIMEOUT if gone is None else gone, seen
    finally:
        alive.destroy_node()
        context.try_shutdown()


def launchers() -> list[tuple[str, Callable[[int, Callable[[], None] | None], Run | None]]]:
    """The launchers to measure: `ros2 launch` where make setup installed it, and spawn."""
    found: list[tuple[str, Callable[[int, Callable[[], None] | None], Run | None]]] = []
    if ROS2.exists() and (VENV / "lib" / "swazure_ros" / "fls").exists():
        found += [(LAUNCH, launch_run), (LAUNCH_PIPED, piped_launch_run)]
    found.append((SPAWN, spawn_run))
    return found


@contextlib.contextmanager
def reserved_domain(domain: int | None) -> Iterator[int]:
    """``domain``, or one reserved machine-wide as the tests reserve theirs."""
    if domain is not None:
        yield domain
        return
    from domain_coordinator import domain_id  # type: ignore[import-untyped]

    with domain_id() as reserved:
        yield int(reserved)


def exits_section(
    args: argparse.Namespace,
    runs: int = RUNS,
    linger_runs: int = LINGER_RUNS,
    domain: int | None = None,
) -> list[str]:
    """Exits over ``runs`` Ctrl-C's of the trio under each launcher, and the stopped
    swarm's nodes on a live peer's graph over ``linger_runs`` more."""
    measured = launchers()
    results: dict[str, list[Run | None]] = {launcher: [] for launcher, _ in measured}
    linger: dict[str, list[tuple[float, int] | None]] = {launcher: [] for launcher, _ in measured}
    loads = []
    with reserved_domain(domain) as reserved:
        for number in range(runs):
            for launcher, run in measured:
                loads.append(float(Path("/proc/loadavg").read_text().split()[0]))
                results[launcher].append(run(reserved, None))
                print(f"bench: exits, {launcher}, run {number + 1} of {runs}", flush=True)
        for launcher, run in measured:
            linger[launcher] = [lingering(run, reserved) for _ in range(linger_runs)]
    return exits_lines(results, linger, loads)


def _codes(codes: Sequence[int], name: Callable[[int], str]) -> str:
    """How many ``codes``, and which (``name`` of each): "0", or "2 (1 ×2)"."""
    if not codes:
        return "0"
    counted = ", ".join(f"{name(code)} ×{n}" for code, n in sorted(Counter(codes).items()))
    return f"{len(codes)} ({counted})"


def _signal_name(code: int) -> str:
    with contextlib.suppress(ValueError):
        return signal.Signals(-code).name
    return f"signal {-code}"


def end_rows(launcher: str, ends: Sequence[End]) -> list[str]:
    """The table's rows of ``launcher``'s ends: one per kind of process."""
    rows = []
    for kind in [kind for kind in KINDS if any(end.kind == kind for end in ends)]:
        own = [end for end in ends if end.kind == kind]
        codes = [end.code for end in own if end.code is not None]
        seconds = [end.seconds for end in own]
        rows.append(
            f"| {launcher} | {KINDS[kind]} | {len(own)} | {codes.count(0)} "
            f"| {_codes([c for c in codes if c > 0], str)} "
            f"| {_codes([c for c in codes if c < 0], _signal_name)} "
            f"| {sum(end.watchdog for end in own)} | {len(own) - len(codes)} "
            f"| {statistics.median(seconds):.2f} | {max(seconds):.2f} |"
        )
    return rows


def exits_lines(
    results: dict[str, list[Run | None]],
    linger: dict[str, list[tuple[float, int] | None]],
    loads: Sequence[float],
) -> list[str]:
    """The section: the table of ends, what bit and what was left, the lingering nodes."""
    runs = max((len(made) for made in results.values()), default=0)
    lines = [
        "## Under load",
        "",
        "### Exits over 100 runs",
        "",
        f"The trio (config/swarms/trio.yaml), one process per FLS, brought up {runs} times "
        "under each launcher and stopped by Ctrl-C once every FLS was on the swarm's radio:",
        "SIGINT to the launcher's process group, as a terminal sends it (`ros2 launch` with",
        "a terminal for its stdin: interactive, so it sends no SIGINT of its own; without",
        "one, as in a script or CI, it sends each process its own SIGINT after). Seconds",
        "from the Ctrl-C to each process's end; a code or signal as its launcher reported",
        "it; a watchdog's line: the teardown's (SIGKILL) or a stop's (exit 1, stacks). "
        f"One-minute load average over the runs: median {statistics.median(loads or [0]):.1f}, "
        f"{min(loads or [0]):.1f} to {max(loads or [0]):.1f} on this machine's 2 cores.",
        "",
        "| launcher | process | ends | exit 0 | other exit code | signal | watchdog line "
        f"| not ended in {END_TIMEOUT:.0f} s | s to end, median | s to end, max |",
        "| --- | --- | ---: | ---: | --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for launcher, made in results.items():
        lines += end_rows(launcher, [end for run in made if run for end in run.ends])
    lines.append("")
    for launcher, made in results.items():
        lines.append(_run_facts(launcher, made, linger.get(launcher, [])))
    return lines


def _run_facts(
    launcher: str, made: Sequence[Run | None], linger: Sequence[tuple[float, int] | None]
) -> str:
    """One paragraph on ``launcher``'s runs: how many came up, bit, left files; lingering."""
    up = [run for run in made if run is not None]
    unclean = [run for run in up if any(end.code != 0 for end in run.ends)]
    left = [run for run in up if run.left]
    text = (
        f"{launcher}: {len(up)} of {len(made)} runs came up; in {len(unclean)} a process "
        f"did not end with code 0, in {sum(run.died_lines > 0 for run in up)} the launcher "
        f"said 'process has died', and {len(left)} left a file behind"
        + (f" ({left[0].left[0]})" if left else "")
        + "."
    )
    measured = [one for one in linger if one is not None]
    if measured:
        seconds = [one[0] for one in measured]
        text += (
            f" A participant alive beside the swarm listed the stopped swarm's nodes for "
            f"{statistics.median(seconds):.1f} s (median; at most {max(seconds):.1f} s) "
            f"after every process had ended, over {len(measured)} runs; one made then "
            f"listed at most {max(one[1] for one in measured)} of them."
        )
    return text
