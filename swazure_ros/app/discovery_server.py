"""Fast DDS's Discovery Server for a swarm: start the servers it names, point processes at them.

Under simple discovery every participant announces itself and its endpoints
to every other, by multicast and then unicast, so discovery traffic and work
grow with the square of the participants: with one process per FLS, with the
square of the FLSs. Under the Discovery Server every participant is a client
that tells one server (or several, for redundancy) what it has, and hears
back only about the endpoints that match its own topics.

Processes find the servers through ``ROS_DISCOVERY_SERVER`` (``IP:PORT;...``,
the position of an address is its server's id), the way the ROS 2 and Fast
DDS documentation set it up: one variable that works the same for our
programs, ``ros2`` and any other ROS 2 node, with no file to copy to every
machine. An XML profile would be the choice for what the variable cannot say
(lease durations, TCP transports); nothing here needs it. A process that
watches the whole graph (the launcher, which waits until every FLS is there,
and ``ros2`` on the command line) must be a *super client*
(``ROS_SUPER_CLIENT=TRUE``), which hears about every endpoint; an FLS is a
plain client.
"""

from __future__ import annotations

import ipaddress
import os
import signal
import socket
import subprocess
import sys
import sysconfig
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from ..core.errors import SwazureError
from ..ros.plumbing import shared_memory

#: The port a server listens on unless told otherwise (Fast DDS's default).
DEFAULT_PORT = 11811
#: Seconds a server has to say it is running.
START_TIMEOUT = 10.0
#: What a server prints once it listens.
RUNNING = "Server is running"


@dataclass(frozen=True)
class ServerAddress:
    """Where one discovery server listens: an IPv4 address and a UDP port."""

    host: str
    port: int = DEFAULT_PORT

    def __str__(self) -> str:
        return f"{self.host}:{self.port}"


def parse_servers(text: str) -> tuple[ServerAddress, ...]:
    """Servers from ``IP[:PORT]`` entries split by ``,`` or ``;``; ValueError for a bad one."""
    entries = [entry.strip() for entry in text.replace(";", ",").split(",")]
    if not any(entries):
        raise ValueError("no discovery server named")
    servers = []
    for entry in entries:
        host, _, port = entry.partition(":")
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise ValueError(f"discovery server '{entry}': not an IPv4 address") from None
        if port and not (port.isdigit() and 0 < int(port) < 65536):
            raise ValueError(f"discovery server '{entry}': port must be 1..65535")
        servers.append(ServerAddress(host, int(port) if port else DEFAULT_PORT))
    if len(set(servers)) != len(servers):
        raise ValueError(f"discovery servers '{text}': one is named twice")
    return tuple(servers)


def client_environment(servers: tuple[ServerAddress, ...], super_client: bool) -> dict[str, str]:
    """The environment that makes a ROS 2 process a client of ``servers`` (or a super client)."""
    environment = {"ROS_DISCOVERY_SERVER": ";".join(str(server) for server in servers)}
    if super_client:
        environment["ROS_SUPER_CLIENT"] = "TRUE"
    return environment


def is_local(host: str) -> bool:
    """True when ``host`` is an address of this machine (its network namespace)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind((host, 0))
        except OSError:
            return False
    return True


def server_command(index: int, server: ServerAddress) -> list[str]:
    """The command line of server ``index`` (its position in ROS_DISCOVERY_SERVER)."""
    program = Path(sys.executable).parent / "fast-discovery-server"
    return [str(program), "-i", str(index), "-l", server.host, "-p", str(server.port)]


def server_environment() -> dict[str, str]:
    """The environment the server's binary needs: the Fast DDS libraries of the venv's wheels."""
    # The wheel ships the binary without a run path to its libraries.
    folders = [
        Path(sys.prefix) / "lib",
        Path(sysconfig.get_path("purelib")) / "ros_fastrtps.libs",
    ]
    inherited = os.environ.get("LD_LIBRARY_PATH", "")
    paths = [str(folder) for folder in folders] + ([inherited] if inherited else [])
    return {**os.environ, "LD_LIBRARY_PATH": os.pathsep.join(paths)}


class DiscoveryServers:
    """The discovery servers of a swarm that run on this machine, started and stopped here."""

    def __init__(self, servers: tuple[ServerAddress, ...], log_dir: Path) -> None:
        self.servers = servers
        self.log_dir = log_dir
        self.processes: dict[int, subprocess.Popen[bytes]] = {}
        self._logs: dict[int, IO[bytes]] = {}

    def log(self, index: int) -> Path:
        """The log file of server ``index``."""
        return self.log_dir / f"discovery_server_{index}.log"

    def start(self) -> list[int]:
        """Start every named server whose address is this machine's; return their indices."""
        local = [index for index, server in enumerate(self.servers) if is_local(server.host)]
        if local:
            self.log_dir.mkdir(parents=True, exist_ok=True)
        for index in local:
            log = self.log(index).open("wb")
            self._logs[index] = log
            self.processes[index] = subprocess.Popen(
                server_command(index, self.servers[index]),
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
                env=server_environment(),
                start_new_session=True,
            )
        for index in local:
            self._wait_running(index)
        return local

    def _wait_running(self, index: int) -> None:
        deadline = time.monotonic() + START_TIMEOUT
        while RUNNING not in self.log(index).read_text(errors="replace"):
            code = self.processes[index].poll()
            if code is not None or time.monotonic() > deadline:
                said = self.log(index).read_text(errors="replace").strip().splitlines()
                how = f"ended with code {code}" if code is not None else "did not start"
                last = f": {said[-1]}" if said else ""
                raise SwazureError(
                    f"discovery server {index} ({self.servers[index]}) {how}{last} "
                    f"(log: {self.log(index)})"
                )
            time.sleep(0.05)

    def stop(self) -> None:
        """Stop every server started here (SIGINT, then SIGKILL after 5 s)."""
        for process in self.processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for process in self.processes.values():
            try:
                process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                shared_memory.kill(process)
        for log in self._logs.values():
            log.close()
