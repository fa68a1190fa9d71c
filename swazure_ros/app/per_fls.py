"""One OS process per FLS: the standalone FLS program, started, watched and stopped.

:class:`FlsProcesses` runs the program ``ros2 run swazure_ros fls`` runs
(:func:`swazure_ros.ros.programs.fls_program.main`) once per FLS, as each FLS of real
hardware runs on its own computer. Every process takes its id, the swarm's
description and key as program arguments, its node's parameters from one
parameter file, and writes its output to a log file of its own
(``fls_<id>.log``). A process that ends early is reported with its exit code
and the last line it wrote; :meth:`FlsProcesses.stop` asks every process to
stop with the swarm (SIGINT: it leaves without telling its peers, as nobody is
left to hear it; ``process.SWARM_STOP_VARIABLE``), kills (SIGKILL) what has
not ended by the deadline, so that nothing is left running, and removes the
swarm's key from the log folder.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import yaml

from ..core.errors import SwazureError
from ..files.atomic import atomic_write
from ..files.description import SwarmDescription
from ..ros.plumbing import shared_memory
from ..ros.plumbing.names import node_name
from ..ros.plumbing.process import SWARM_STOP_VARIABLE
from ..ros.plumbing.startup import description_parameters, startup_arguments
from ..ros.programs import fls_program
from ..ros.security.auth import SwarmKey
from ..ros.security.keys import write_key
from .discovery_server import ServerAddress, client_environment

#: How much lower than the launcher's the FLS processes' CPU priority is (nice). A real
#: FLS has a computer of its own; here hundreds share a few cores with the simulator
#: and the discovery server, which every FLS waits for. At equal priority, 200 FLS
#: processes on 2 cores starved them: the server got a few per cent of a core, and 49
#: FLSs were still unknown to the launcher after 300 s (2026-11-26).
FLS_NICENESS = 10
#: What starts one FLS: the standalone program, as ``ros2 run swazure_ros fls``.
FLS_PROGRAM = (
    sys.executable,
    "-c",
    # The launcher's pipe (FlsProcesses._pipe): its end of file, when the launcher dies even
    # by SIGKILL, sends the FLS SIGINT, so that no FLS outlives the swarm it belonged to; the
    # swarm ends with its launcher, and the FLS leaves as in any stop of the whole swarm.
    "import os, signal, sys, threading; "
    "pipe = int(sys.argv.pop(1)); "
    "threading.Thread(target=lambda: (os.read(pipe, 1), os.kill(os.getpid(), signal.SIGINT)), "
    "daemon=True).start(); "
    # Once: a program that starts itself afresh (fls_program.start_afresh) is at it already.
    f"os.environ.get({fls_program.STARTED_AFRESH!r}) or os.nice({FLS_NICENESS}); "
    "from swazure_ros.ros.programs.fls_program import main; sys.exit(main())",
)
#: The environment of an FLS process, unless the user's sets it: UDP only, as between
#: FLSs on computers of their own. Over Fast DDS's shared memory, some of 25 FLS
#: processes on one host missed their first, latched camera frame in about half of
#: the bring-ups, over UDP in 1 of 19 (measured 2026-11-26; the simulated cameras
#: now stream, ros.nodes.world_node.SimulatedCameras); UDP also keeps 6 MB less resident.
#: NUMBA_DISABLE_JIT: one FLS relaxes a few labels a round, where numba would cost more
#: than it saves (core.jit).
FLS_ENVIRONMENT = {"FASTDDS_BUILTIN_TRANSPORTS": "UDPv4", "NUMBA_DISABLE_JIT": "1"}
#: Seconds between two FLS processes' starts. Started at once, 25 FLS processes on
#: this host left one or two of them deaf to the simulator's participant (no camera
#: frame, no node names; their endpoints still discovered) in 4 of 12 bring-ups;
#: 0.2 s apart, in none of 16 (2026-11-26). Participants created at the same moment
#: are known to collide in Fast DDS (rmw_fastrtps#80: the same participant id, so the
#: same unicast port).
START_INTERVAL = 0.2
#: Seconds a process has to end after SIGINT before it is killed: beyond its own limits
#: (process.STOP_LIMIT, then process.PROGRAM_TEARDOWN_LIMIT), so that one that hangs says
#: where in its log. When every process tore its participant down at once, one took more
#: than 10 s on 2 cores under a test run; stopped with the swarm, none tears it down now.
STOP_GRACE = 20.0


@dataclass(frozen=True)
class Ended:
    """An FLS process that has ended: its exit code and the last line of its output."""

    fls_id: int
    code: int  # negative: killed by that signal
    last_line: str

    def describe(self) -> str:
        """One line for people: which FLS, how it ended, what it said last."""
        how = f"signal {-self.code}" if self.code < 0 else f"code {self.code}"
        said = f": {self.last_line}" if self.last_line else ""
        return f"FLS {self.fls_id}'s process ended with {how}{said}"


def last_line(path: Path, tail: int = 4096) -> str:
    """The last non-empty line of file ``path`` (its last ``tail`` bytes), or ""."""
    try:
        with path.open("rb") as log:
            log.seek(max(path.stat().st_size - tail, 0))
            lines = log.read().decode("utf-8", "replace").splitlines()
    except OSError:
        return ""
    return next((line.strip() for line in reversed(lines) if line.strip()), "")


def peak_rss_mb(pid: int) -> float:
    """Peak resident memory of process ``pid`` (VmHWM), MB; NaN once it has ended."""
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return float("nan")


def fls_arguments(
    description: SwarmDescription,
    namespace: str,
    key_file: Path | None,
    instance: bytes,
    startup: dict[str, object],
) -> list[str]:
    """The startup arguments every FLS's program takes: the swarm's description and key,
    and ``startup``'s values of its other startup parameters (``track.motion``)."""
    values = {
        **startup,
        **description_parameters(description),
        "namespace": namespace,
        "key_file": "" if key_file is None else str(key_file),
        "swarm_instance": instance.hex() if key_file is not None else "",
    }
    return startup_arguments(values, fls_program.STARTUP)


def parameter_file(
    namespace: str,
    parameters: Mapping[str, object],
    fls_parameters: Mapping[int, Mapping[str, object]],
) -> dict[str, object]:
    """The parameter file's content: the node parameters of every FLS, then each's own."""
    content: dict[str, object] = {"/**": {"ros__parameters": dict(parameters)}}
    for fls_id, own in sorted(fls_parameters.items()):
        content[f"/{namespace}/{node_name(fls_id)}"] = {"ros__parameters": dict(own)}
    return content


class FlsProcesses:
    """The FLS processes of a swarm that runs one FLS to a process."""

    def __init__(
        self,
        description: SwarmDescription,
        fls_ids: Sequence[int],
        log_dir: Path,
        *,
        namespace: str = "swarm",
        key: SwarmKey | None = None,
        parameters: Mapping[str, object] | None = None,
        fls_parameters: Mapping[int, Mapping[str, object]] | None = None,
        params_file: str | None = None,
        domain_id: int | None = None,
        discovery_servers: tuple[ServerAddress, ...] = (),
    ) -> None:
        self.fls_ids = [int(fls_id) for fls_id in fls_ids]
        self.log_dir = log_dir
        log_dir.mkdir(parents=True, exist_ok=True)
        #: The swarm's key, written for the FLS processes to read; removed when they stop.
        self.key_file: Path | None = None
        instance = b""
        if key is not None and key.active:
            secret, instance = key.material
            assert secret is not None
            self.key_file = log_dir / "swarm.key"
            write_key(self.key_file, secret)
        self.parameters_path = log_dir / "parameters.yaml"
        # The program's startup parameters among ``parameters`` are its arguments.
        given = parameters or {}
        startup = {spec.name for spec in fls_program.STARTUP}
        at_start = {name: value for name, value in given.items() if name in startup}
        self._arguments = fls_arguments(description, namespace, self.key_file, instance, at_start)
        node_parameters = {name: value for name, value in given.items() if name not in startup}
        content = parameter_file(namespace, node_parameters, fls_parameters or {})
        atomic_write(
            self.parameters_path,
            lambda path: path.write_text(yaml.safe_dump(content, sort_keys=False)),
        )
        # A user's parameter file first: the launcher's own settings win over it.
        files = [params_file] if params_file else []
        self._files = [*files, str(self.parameters_path)]
        # A SIGINT from this launcher (stop) or from its end (FLS_PROGRAM) stops the swarm.
        self._environment = {**FLS_ENVIRONMENT, **os.environ, SWARM_STOP_VARIABLE: "1"}
        if domain_id is not None:
            self._environment["ROS_DOMAIN_ID"] = str(domain_id)
        if discovery_servers:
            # A plain client: an FLS hears only of the endpoints that match its own.
            self._environment.pop("ROS_SUPER_CLIENT", None)
            self._environment.update(client_environment(discovery_servers, super_client=False))
        self.processes: dict[int, subprocess.Popen[bytes]] = {}
        self._logs: dict[int, IO[bytes]] = {}
        # Every FLS reads the end of this pipe; only the launcher holds its writing end, so
        # that its death, even by SIGKILL, is every FLS's end of file (FLS_PROGRAM).
        self._pipe = os.pipe()

    def log(self, fls_id: int) -> Path:
        """The log file of FLS ``fls_id``'s process."""
        return self.log_dir / f"{node_name(fls_id)}.log"

    def command(self, fls_id: int) -> list[str]:
        """The command line of FLS ``fls_id``'s process."""
        files = [part for path in self._files for part in ("--params-file", path)]
        startup = ["--fls-id", str(fls_id), *self._arguments]
        return [*FLS_PROGRAM, str(self._pipe[0]), *startup, "--ros-args", *files]

    def start(self, interval: float = START_INTERVAL) -> None:
        """Start every FLS's process, in id order, ``interval`` s apart."""
        for count, fls_id in enumerate(self.fls_ids):
            if count:
                time.sleep(interval)
            self._launch(fls_id, "wb")

    def restart(self, fls_id: int) -> None:
        """Start FLS ``fls_id``'s process again, as it was started, once it has ended.

        As a person would start a crashed FLS again: the same id and
        arguments, its log going on after its last life's. The swarm takes it
        back once the graph shows its node again (docs/protocol.md, "Coming
        back"). SwazureError for an FLS not started here, or still running.
        """
        process = self.processes.get(fls_id)
        if process is None:
            raise SwazureError(f"FLS {fls_id} has no process here to start again")
        if process.poll() is None:
            raise SwazureError(f"FLS {fls_id}'s process (pid {process.pid}) is still running")
        self._logs.pop(fls_id).close()
        self._launch(fls_id, "ab")

    def _launch(self, fls_id: int, mode: str) -> None:
        """Start FLS ``fls_id``'s process, its output to its log opened in ``mode``."""
        log = self.log(fls_id).open(mode)
        self._logs[fls_id] = log
        self.processes[fls_id] = subprocess.Popen(
            self.command(fls_id),
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            env=self._environment,
            # Its own process group: a Ctrl-C at the terminal reaches the launcher
            # alone, which then stops every FLS in order (stop).
            start_new_session=True,
            pass_fds=(self._pipe[0],),
        )

    def ended(self) -> list[Ended]:
        """The processes that have ended so far, in id order."""
        return [
            Ended(fls_id, code, last_line(self.log(fls_id)))
            for fls_id, process in self.processes.items()
            if (code := process.poll()) is not None
        ]

    def peak_rss_mb(self) -> list[float]:
        """Peak resident memory of every process, MB, in id order."""
        return [peak_rss_mb(process.pid) for process in self.processes.values()]

    def stop(self, grace: float = STOP_GRACE) -> list[Ended]:
        """Stop every process with the swarm (SIGINT, then SIGKILL after ``grace`` s) and
        remove the swarm's key; how each ended."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace
        for process in self.processes.values():
            try:
                process.wait(timeout=max(deadline - time.monotonic(), 0.0))
            except subprocess.TimeoutExpired:
                shared_memory.kill(process)
        for log in self._logs.values():
            log.close()
        for end in self._pipe:
            with contextlib.suppress(OSError):
                os.close(end)
        if self.key_file is not None:
            # Read by each process at its start; no secret outlives the swarm in a folder.
            self.key_file.unlink(missing_ok=True)
        return self.ended()
