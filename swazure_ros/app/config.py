"""What a swarm is brought up with: its world, processes, ROS settings, key and view."""

from __future__ import annotations

from dataclasses import dataclass, field

from ..core.errors import SwazureError
from ..sim.world import WorldSpec
from .discovery_server import ServerAddress


@dataclass(frozen=True)
class SwarmConfig:
    """How to bring a swarm up."""

    world: WorldSpec
    processes: int = 1
    namespace: str = "swarm"
    params_file: str | None = None
    domain_id: int | None = None
    discovery_timeout: float = 600.0
    #: This process hosts share ``share`` of ``hosts`` (one per machine of a swarm
    #: across hosts, each started by hand); share 0 also runs the world node and
    #: the coordinator. hosts = 1: the whole swarm from here (``processes``).
    share: int = 0
    hosts: int = 1
    #: ROS parameters of every FLS node, and of single FLSs (id -> name -> value),
    #: over the parameter file's.
    parameters: dict[str, object] = field(default_factory=dict)
    fls_parameters: dict[int, dict[str, object]] = field(default_factory=dict)
    #: Record every topic of the swarm to this MCAP file (share 0's process).
    record: str | None = None
    #: Show the swarm (RViz markers; Foxglove on view.port), from share 0's process.
    view: ViewConfig | None = None
    #: The swarm's key (ros.security.auth): every protocol message is signed with it and checked.
    #: None: a fresh one for a swarm whose every process starts here; across hosts,
    #: each share must be given the same key, or the swarm runs without one.
    key: bytes | None = field(default=None, repr=False)
    #: False: no key at all; any peer on the domain may then speak for the swarm, and
    #: only what the FLSs can check of a message protects them (docs/security.md).
    authenticate: bool = True
    #: Every FLS node offers parameter services (``ros2 param``): six more services a
    #: node, which a packed swarm of thousands pays for in bring-up (BENCHMARKS.md).
    parameter_services: bool = False
    #: One OS process per FLS (the standalone FLS program, app.per_fls), beside this
    #: process's simulator and coordinator: the topology of real FLS hardware.
    per_fls: bool = False
    #: per_fls: where each FLS process's output goes (fls_<id>.log); None: a new
    #: temporary folder.
    log_dir: str | None = None
    #: Discover through these Fast DDS Discovery Servers instead of simple discovery
    #: (app.discovery_server); those whose address is this host's are started here.
    discovery_servers: tuple[ServerAddress, ...] = ()

    def __post_init__(self) -> None:
        # The one check of how a swarm's processes are laid out: the command line
        # builds this config, and a program that builds one gets the same words.
        if self.processes < 1:
            raise SwazureError(f"--processes must be at least 1, got {self.processes}")
        if self.hosts > 1 and self.processes > 1:
            raise SwazureError("--share runs one process per host: leave out --processes")
        if not 0 <= self.share < self.hosts:
            raise SwazureError(f"--share {self.share}/{self.hosts}: no such share")
        if self.per_fls and self.processes > 1:
            raise SwazureError("--per-fls runs one process per FLS: leave out --processes")


@dataclass(frozen=True)
class ViewConfig:
    """What the view shows first, and where Foxglove finds it."""

    port: int = 8765
    colour_by: str = "ranges"  # or "status": each FLS's share of sweet paths (the engine's)
    seen_from: int | None = None  # colour_by ranges: seen from this FLS (default the first)
    policy: str = "shortest-length"  # colour_by status and pairs: the paths' policy
    pairs: tuple[tuple[int, int], ...] = ()  # ordered blind pairs whose paths to draw
