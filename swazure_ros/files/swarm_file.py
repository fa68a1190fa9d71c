"""A swarm in one file (config/swarms/*.yaml): its format, read into a typed record.

Like Crazyswarm2's crazyflies.yaml, one versioned file says which swarm to bring up::

    fileversion: 1
    swarm:
      cloud: torus:120          # a built-in shape, or a cloud file (relative to this file)
      beta: 0.5                 # or radius: (cm)
      processes: 2
      parameters:               # every FLS node's ROS parameters, over the params file
        publish_period: 0.5
      fls:                      # one FLS's parameters, over those
        12: {publish_period: 0.1}

Keys under ``swarm:`` are the long options of ``swazure spawn`` with ``_`` for
``-`` (:data:`OPTIONS`), each checked by the rule the flag's value meets
(``files.values``), so a bad file gets one line naming the file and the key.
A file without ``fileversion`` is read as version 1: the format had no
version before version 1, and every such file is one. A file of a version
this release does not read is refused in one line that names both.

:func:`read_swarm_file` checks what the file's format says. What ROS and the
FLS node say of its values (a ROS namespace; ``parameters`` and ``fls``, each
an FLS node's own parameter) is theirs to check, in the layers above:
``app.config.load_swarm_file`` reads a file through this one and checks those.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

from ..core.errors import CloudError, SwazureError
from ..core.paths import POLICIES
from . import values
from .cloud_files import is_cloud_path
from .reading import config_dir, read_yaml

#: The version of the format this release writes in its examples.
FILE_VERSION = 1
#: The versions of the format this release reads.
READ_VERSIONS = (1,)

#: A ROS parameter's value as a swarm file gives it: a scalar, or a list of one kind.
ParameterValue = bool | int | float | str | list[bool] | list[int] | list[float] | list[str]
#: ROS parameters of a node by name, nested names flattened with dots (``track.service``).
NodeParameters = dict[str, ParameterValue]

#: Scalars a ROS parameter can be (its types).
_SCALARS = (bool, int, float, str)
T = TypeVar("T")


def _flag(text: str) -> bool:
    if text not in ("True", "False"):
        raise ValueError(f"{text!r}: expected true or false")
    return text == "True"


def _policy(text: str) -> str:
    if text not in POLICIES:
        raise ValueError(f"{text!r}: expected one of {', '.join(POLICIES)}")
    return text


#: Option -> the rule of its value as text (the flag's own where it has one). Paths are
#: resolved against the swarm file's folder before their rule. The namespace is checked
#: as a ROS name above this layer (``app.config.load_swarm_file``).
_RULES: dict[str, Callable[[str], object]] = {
    "cloud": str,
    "scale": values.number,
    "beta": values.number,
    "radius": values.number,
    "sensor": values.input_file,
    "accurate": _flag,
    "seed": values.seed,
    "resample": values.resample_count,
    "policy": _policy,
    "processes": values.count,
    "params": values.input_file,
    "namespace": str,
    "domain_id": values.domain_id,
    "discovery_timeout": values.seconds,
}
#: The options a swarm file may give under ``swarm:``: spawn's long options, ``_`` for ``-``.
OPTIONS = tuple(_RULES)
#: Options whose value is a path; a relative one is taken from the file's folder.
PATHS = ("sensor", "params")
#: The keys besides the options: ROS parameters of every FLS node, and of one FLS.
PARAMETER_KEYS = ("parameters", "fls")


@dataclass(frozen=True)
class SwarmFile:
    """What a swarm file says, checked: each option None where the file leaves it out.

    ``parameters`` are every FLS node's ROS parameters and ``fls`` one FLS's
    (FLS id -> parameters), empty where the file gives none. Paths are absolute.
    """

    path: Path
    version: int = FILE_VERSION
    cloud: str | None = None
    scale: float | None = None
    beta: float | None = None
    radius: float | None = None
    sensor: Path | None = None
    accurate: bool | None = None
    seed: int | None = None
    resample: int | None = None
    policy: str | None = None
    processes: int | None = None
    params: Path | None = None
    namespace: str | None = None
    domain_id: int | None = None
    discovery_timeout: float | None = None
    parameters: NodeParameters = field(default_factory=dict)
    fls: dict[int, NodeParameters] = field(default_factory=dict)


def read_swarm_file(path: Path) -> SwarmFile:
    """The swarm file at ``path``, read and checked by its format.

    Parameters
    ----------
    path : Path
        A swarm file (YAML, at most ``files.reading.CONFIG_BYTES``).

    Returns
    -------
    SwarmFile
        Its options, its FLS nodes' parameters and its version.

    Raises
    ------
    SwazureError
        In one line that names the file and the key of the first thing wrong: not
        YAML, not a swarm file, a version this release does not read, an unknown
        key, a value its option's rule refuses, beta and radius both given.
    """
    document = read_yaml(path, "swarm", SwazureError)
    if not isinstance(document, dict):
        raise SwazureError(f"{path}: a swarm file is a mapping with the key swarm:")
    # First: a file of another version may be another format altogether.
    version = _version(path, document.get("fileversion", 1))
    section = document.get("swarm")
    if not isinstance(section, dict):
        raise SwazureError(f"{path}: a swarm file is a mapping with the key swarm:")
    extra = sorted(str(key) for key in document if key not in ("fileversion", "swarm"))
    if extra:
        raise SwazureError(f"{path}: unknown top-level key {extra[0]!r} (fileversion: and swarm:)")
    given = {str(key): value for key, value in section.items()}
    options = {key: _option(path, key, value) for key, value in given.items()}
    beta, radius = _typed(options, "beta", float), _typed(options, "radius", float)
    if beta is not None and radius is not None:
        raise CloudError(f"{path}: give beta or radius, not both")
    return SwarmFile(
        path,
        version,
        cloud=_typed(options, "cloud", str),
        scale=_typed(options, "scale", float),
        beta=beta,
        radius=radius,
        sensor=_typed(options, "sensor", Path),
        accurate=_typed(options, "accurate", bool),
        seed=_typed(options, "seed", int),
        resample=_typed(options, "resample", int),
        policy=_typed(options, "policy", str),
        processes=_typed(options, "processes", int),
        params=_typed(options, "params", Path),
        namespace=_typed(options, "namespace", str),
        domain_id=_typed(options, "domain_id", int),
        discovery_timeout=_typed(options, "discovery_timeout", float),
        parameters=_parameters(path, "parameters", given.get("parameters")),
        fls=_fls_parameters(path, given.get("fls")),
    )


def _version(path: Path, found: object) -> int:
    """The file's version, if this release reads it; SwazureError naming both if not."""
    if type(found) is int and found in READ_VERSIONS:
        return found
    readable = ", ".join(str(version) for version in READ_VERSIONS)
    raise SwazureError(
        f"{path}: fileversion {found!r}, and this release reads swarm files of fileversion "
        f"{readable}"
    )


def _option(path: Path, key: str, value: object) -> object:
    """``value`` of ``key`` as its option takes it; SwazureError when it cannot be."""
    if key in PARAMETER_KEYS:
        return None  # read by _parameters and _fls_parameters
    rule = _RULES.get(key)
    if rule is None:
        known = ", ".join([*OPTIONS, *PARAMETER_KEYS])
        raise SwazureError(f"{path}: unknown key {key!r} under swarm: (known: {known})")
    if value is None:
        return None  # as if the key were absent: the flag's default
    if isinstance(value, (dict, list)):
        raise SwazureError(
            f"{path}: swarm.{key}: expected one value, got a {type(value).__name__}"
        )
    text = str(value)
    if key in PATHS or (key == "cloud" and is_cloud_path(text)):
        text = str((path.parent / Path(text).expanduser()).resolve())
    try:
        return rule(text)
    except ValueError as err:
        raise SwazureError(f"{path}: swarm.{key}: {err}") from None


def _typed(options: Mapping[str, object], key: str, kind: type[T]) -> T | None:
    """Option ``key``'s value, of the ``kind`` its rule returns; None when not given."""
    value = options.get(key)
    if value is None or isinstance(value, kind):
        return value
    raise TypeError(f"swarm.{key}: its rule gave a {type(value).__name__}, not a {kind}")


def _parameters(path: Path, key: str, value: object) -> NodeParameters:
    """A mapping of ROS parameters, nested names flattened with dots (track.service)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SwazureError(f"{path}: swarm.{key}: expected a mapping of ROS parameters")
    flat: NodeParameters = {}
    for name, item in value.items():
        where = f"{key}.{name}"
        if isinstance(item, Mapping) and not item:
            raise SwazureError(f"{path}: swarm.{where}: an empty mapping sets no parameter")
        if isinstance(item, Mapping):
            for inner, inner_value in _parameters(path, where, item).items():
                flat[f"{name}.{inner}"] = inner_value
        elif isinstance(item, _SCALARS) or (
            isinstance(item, list)
            and item
            and isinstance(item[0], _SCALARS)
            and all(type(x) is type(item[0]) for x in item)
        ):
            flat[str(name)] = item
        else:
            raise SwazureError(
                f"{path}: swarm.{where}: a ROS parameter is a number, a string, true/false "
                "or a list of one of those"
            )
    return flat


def _fls_parameters(path: Path, value: object) -> dict[int, NodeParameters]:
    """FLS id -> its ROS parameters."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SwazureError(f"{path}: swarm.fls: expected FLS ids, each with its parameters")
    flss: dict[int, NodeParameters] = {}
    for fls, parameters in value.items():
        try:
            fls_id = values.fls_id(str(fls))
        except ValueError as err:
            raise SwazureError(f"{path}: swarm.fls: {err}") from None
        flss[fls_id] = _parameters(path, f"fls.{fls_id}", parameters)
    return flss


def example_swarms() -> list[str]:
    """The names of the example swarm files installed with the package (config/swarms/)."""
    return sorted(path.stem for path in (config_dir() / "swarms").glob("*.yaml"))


def find_swarm_file(text: str) -> Path:
    """A swarm file: a path, or the bare name of an example (``torus``, ``trio.yaml``).

    A path that exists wins; a bare name is looked up in the installed
    config/swarms/, so that it works from any folder, as ``ros2 launch`` is run.
    ValueError in one line when it names neither.
    """
    given = Path(text).expanduser()
    if not given.exists() and given.name == text:
        stem = given.name.removesuffix(".yaml")
        example = config_dir() / "swarms" / f"{stem}.yaml"
        if example.is_file():
            return example
        if not given.suffix:
            raise ValueError(
                f"{text}: no such file, nor an example swarm ({', '.join(example_swarms())})"
            )
    return values.input_file(str(given))
