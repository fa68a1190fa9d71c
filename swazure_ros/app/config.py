"""What a swarm is brought up with: its world, processes, ROS settings, key and view.

A swarm file (``files.swarm_file``) gives part of it: :func:`load_swarm_file` reads one
and checks what ROS and the FLS node say of its values, and :func:`config_from_file`
makes the :class:`SwarmConfig` it describes alone, as the launch file brings it up.
``swazure spawn FILE`` makes one from the file with its flags over it
(``cli.spawn.config_from_args``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypeVar

from ..core.errors import CloudError, SwazureError
from ..files.description import DEFAULT_CLOUD
from ..files.reading import config_dir
from ..files.swarm_file import NodeParameters, SwarmFile, read_swarm_file
from ..ros.nodes.fls_parameters import checked_parameters
from ..sim.world import WorldSpec
from .discovery_server import ServerAddress

T = TypeVar("T")


#: Who answers an FLS's get_neighbours (SwarmConfig.neighbour_services).
AUTO, FLS, HOSTS = "auto", "fls", "hosts"
NEIGHBOUR_SERVICES = (AUTO, FLS, HOSTS)
#: The largest swarm whose FLSs each offer get_neighbours under AUTO: the published shapes
#: (the race car has 3,720 FLSs). Measured 2026-11-30, 5,000 FLS nodes created in one process:
#: 5.8 s with a publisher each, 102 s with a get_neighbours service too (the last thousand 40 s).
FLS_SERVICES_UP_TO = 4_000


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
    parameters: NodeParameters = field(default_factory=dict)
    fls_parameters: dict[int, NodeParameters] = field(default_factory=dict)
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
    #: Who answers an FLS's ``get_neighbours``: ``fls``, each FLS itself; ``hosts``, its
    #: process's host node only; ``auto``, as :meth:`fls_services` says.
    neighbour_services: str = AUTO
    #: The launching process's world holds every pair of the swarm, as the view and the
    #: swarm's heuristics and fits need; False: only its own FLSs' pairs, as a further
    #: process's world (``--compute-all`` of plain Swazure then compares block by block).
    whole_world: bool = True

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
        if self.neighbour_services not in NEIGHBOUR_SERVICES:
            raise SwazureError(
                f"--neighbour-services must be one of {', '.join(NEIGHBOUR_SERVICES)}, "
                f"got {self.neighbour_services!r}"
            )
        if self.per_fls and self.neighbour_services == HOSTS:
            raise SwazureError(
                "--neighbour-services hosts: an FLS of --per-fls is alone in its process "
                "and answers for itself"
            )

    def fls_services(self, swarm_size: int) -> bool:
        """Whether each FLS of a swarm of ``swarm_size`` offers ``get_neighbours`` itself.

        ``auto``: up to :data:`FLS_SERVICES_UP_TO` FLSs (every published shape),
        and always one FLS to a process (``per_fls``). Above, hosts answer: a
        service is two endpoints, and Fast DDS pairs each new endpoint with every
        one its participant has, so a process's bring-up grows with the square of
        its FLSs' services (docs/swarm.md).
        """
        if self.neighbour_services == AUTO:
            return self.per_fls or swarm_size <= FLS_SERVICES_UP_TO
        return self.neighbour_services == FLS


@dataclass(frozen=True)
class ViewConfig:
    """What the view shows first, and where Foxglove finds it."""

    port: int = 8765
    colour_by: str = "ranges"  # or "status": each FLS's share of sweet paths (the engine's)
    seen_from: int | None = None  # colour_by ranges: seen from this FLS (default the first)
    policy: str = "shortest-length"  # colour_by status and pairs: the paths' policy
    pairs: tuple[tuple[int, int], ...] = ()  # ordered blind pairs whose paths to draw


def load_swarm_file(path: Path) -> SwarmFile:
    """The swarm file at ``path``, read by its format and checked by what runs it.

    Parameters
    ----------
    path : Path
        A swarm file (``files.swarm_file``).

    Returns
    -------
    SwarmFile
        Its values, the namespace without its leading slash.

    Raises
    ------
    SwazureError
        In one line naming the file and the key: what ``files.swarm_file.read_swarm_file``
        refuses, a namespace that is not a ROS namespace, and in ``parameters`` or ``fls``
        a parameter that no FLS node has, or a value its rule refuses
        (``ros.nodes.fls_parameters``).
    """
    swarm = read_swarm_file(path)
    namespace = swarm.namespace
    if namespace is not None:
        # Here: rclpy loads only for a swarm file that names its namespace.
        from ..ros.plumbing.names import checked_namespace

        try:
            namespace = checked_namespace(namespace)
        except ValueError as err:
            raise SwazureError(f"{path}: swarm.namespace: {err}") from None
    return replace(
        swarm,
        namespace=namespace,
        parameters=_fls_node_parameters(path, "parameters", swarm.parameters),
        fls={
            fls_id: _fls_node_parameters(path, f"fls.{fls_id}", own)
            for fls_id, own in swarm.fls.items()
        },
    )


def _fls_node_parameters(path: Path, where: str, given: NodeParameters) -> NodeParameters:
    try:
        return checked_parameters(given)
    except ValueError as err:
        # The reason begins with the parameter's name: swarm.fls.3.publish_period must be ...
        raise SwazureError(f"{path}: swarm.{where}.{err}") from None


def params_file(given: Path | None) -> str:
    """The ROS parameter file of a swarm's nodes: the one ``given``, else config/swarm.yaml."""
    return str(given if given is not None else config_dir() / "swarm.yaml")


def config_from_file(swarm: SwarmFile) -> SwarmConfig:
    """The swarm that ``swarm`` describes alone: every option it leaves out at its default.

    The defaults are ``swazure spawn``'s: the cloud ``torus``, one process, the
    namespace ``swarm``, config/swarm.yaml, 600 s to discover the swarm.

    Raises
    ------
    CloudError
        The file gives neither beta nor radius (a command line may give them beside it).
    SwazureError
        What :class:`SwarmConfig` refuses.
    """
    if swarm.beta is None and swarm.radius is None:
        raise CloudError(f"{swarm.path}: give swarm.beta (r = beta * dmin) or swarm.radius (cm)")
    world = WorldSpec(
        cloud=_given(swarm.cloud, DEFAULT_CLOUD),
        scale=swarm.scale,
        beta=swarm.beta,
        radius=swarm.radius,
        sensor_file=None if swarm.sensor is None else str(swarm.sensor),
        accurate=_given(swarm.accurate, WorldSpec.accurate),
        seed=_given(swarm.seed, WorldSpec.seed),
        resample=swarm.resample,
    )
    return SwarmConfig(
        world,
        processes=_given(swarm.processes, SwarmConfig.processes),
        namespace=_given(swarm.namespace, SwarmConfig.namespace),
        params_file=params_file(swarm.params),
        domain_id=swarm.domain_id,
        discovery_timeout=_given(swarm.discovery_timeout, SwarmConfig.discovery_timeout),
        parameters=swarm.parameters,
        fls_parameters=swarm.fls,
    )


def _given(value: T | None, default: T) -> T:
    """``value`` where the file gives it, else the record's own ``default``."""
    return default if value is None else value
