"""A swarm in one file: the options of ``swazure spawn`` as YAML (config/swarms/*.yaml).

Like Crazyswarm2's crazyflies.yaml, one file says which swarm to bring up::

    swarm:
      cloud: torus:120          # a built-in shape, or a cloud file (relative to this file)
      beta: 0.5                 # or radius: (cm)
      processes: 2
      parameters:               # every FLS node's ROS parameters, over the params file
        publish_period: 0.5
      fls:                      # one FLS's parameters, over those
        12: {publish_period: 0.1}

Keys are the long options of ``swazure spawn`` with ``_`` for ``-``; a flag
given on the command line overrides the file. Every value is checked here, as
the flag's would be, so a bad file gets one line naming the file and the key;
``parameters`` and ``fls`` are an FLS node's own, each checked by its spec
(``ros.nodes.fls_parameters``), since a name no FLS node has would be ignored.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..core.errors import SwazureError
from ..core.paths import POLICIES
from ..core.tracking import TRACK_SETTINGS, TrackConfig, TrackingError
from ..files.cloud_files import is_cloud_path
from ..files.reading import config_dir, read_yaml
from ..ros.nodes import fls_parameters
from . import arguments

#: Parameter values a node can take from the file (ROS 2 parameter types).
_SCALARS = (bool, int, float, str)


def _flag(text: str) -> bool:
    if text not in ("True", "False"):
        raise argparse.ArgumentTypeError(f"{text!r}: expected true or false")
    return text == "True"


def _policy(text: str) -> str:
    if text not in POLICIES:
        raise argparse.ArgumentTypeError(f"{text!r}: expected one of {', '.join(POLICIES)}")
    return text


#: Key -> check of its value as text (the flag's own type where it has one).
#: Paths are resolved against the swarm file's folder before their check.
CHECKS: dict[str, Callable[[str], Any]] = {
    "cloud": str,
    "scale": arguments.number,
    "beta": arguments.number,
    "radius": arguments.number,
    "sensor": arguments.input_file,
    "accurate": _flag,
    "seed": arguments.seed,
    "policy": _policy,
    "processes": arguments.count,
    "params": arguments.input_file,
    "namespace": arguments.ros_namespace,
    "domain_id": arguments.domain_id,
    "discovery_timeout": arguments.seconds,
}
#: The FLS node's tracking parameters, checked together by TrackConfig.
TRACK_SETTING_NAMES = frozenset(f"track.{name}" for name in TRACK_SETTINGS)
#: Keys whose value is a path; a relative one is taken from the file's folder.
PATHS = ("sensor", "params")
#: The file's keys besides the options: ROS parameters of every FLS node, and of one.
PARAMETER_KEYS = ("parameters", "fls")


def load_swarm_file(path: Path) -> dict[str, Any]:
    """The options ``path`` sets (keys as in CHECKS, plus parameters and fls), checked.

    ``parameters`` is a flat mapping of ROS parameter names (``track.service``)
    to values; ``fls`` maps FLS ids to such mappings. SwazureError names the
    file and the key of the first thing wrong.
    """
    document = read_yaml(path, "swarm", SwazureError)
    if not isinstance(document, dict) or not isinstance(document.get("swarm"), dict):
        raise SwazureError(f"{path}: a swarm file is a mapping with one key, swarm:")
    if set(document) != {"swarm"}:
        extra = sorted(str(key) for key in document if key != "swarm")
        raise SwazureError(f"{path}: unknown top-level key {extra[0]!r} (only swarm:)")
    options: dict[str, Any] = {}
    for key, value in document["swarm"].items():
        options[key] = _checked(path, str(key), value)
    arguments.check_beta_or_radius(options.get("beta"), options.get("radius"), str(path))
    return options


def _checked(path: Path, key: str, value: Any) -> Any:
    """``value`` of ``key`` as the option takes it; SwazureError when it cannot be."""
    if key == "parameters":
        return _fls_node_parameters(path, key, _parameters(path, key, value))
    if key == "fls":
        return _fls_parameters(path, value)
    check = CHECKS.get(key)
    if check is None:
        known = ", ".join([*CHECKS, *PARAMETER_KEYS])
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
        return check(text)
    except argparse.ArgumentTypeError as err:
        raise SwazureError(f"{path}: swarm.{key}: {err}") from None


def _parameters(path: Path, key: str, value: Any) -> dict[str, Any]:
    """A mapping of ROS parameters, nested names flattened with dots (track.service)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SwazureError(f"{path}: swarm.{key}: expected a mapping of ROS parameters")
    flat: dict[str, Any] = {}
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


def _fls_parameters(path: Path, value: Any) -> dict[int, dict[str, Any]]:
    """FLS id -> its ROS parameters."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise SwazureError(f"{path}: swarm.fls: expected FLS ids, each with its parameters")
    flss: dict[int, dict[str, Any]] = {}
    for fls, parameters in value.items():
        try:
            fls_id = arguments.fls_id(str(fls))
        except argparse.ArgumentTypeError as err:
            raise SwazureError(f"{path}: swarm.fls: {err}") from None
        where = f"fls.{fls_id}"
        flss[fls_id] = _fls_node_parameters(path, where, _parameters(path, where, parameters))
    return flss


def _fls_node_parameters(path: Path, where: str, flat: dict[str, Any]) -> dict[str, Any]:
    """``flat``'s ROS parameters, each one an FLS node has, of its type, by its rule.

    A name no FLS node declares would be ignored by every node without a word
    (the coordinator's ``round_timeout`` among them): it is refused here. A
    whole number where the parameter is a double is taken as that double, as
    the flag would take it (rclpy refuses an integer for a double).
    """
    specs = {spec.name: spec for spec in (*fls_parameters.EVERY, fls_parameters.RCLPY_OWN)}
    checked: dict[str, Any] = {}
    for name, value in flat.items():
        spec = specs.get(name)
        if spec is None:
            known = [other for other in specs if not other.startswith("track.")] + ["track.*"]
            raise SwazureError(
                f"{path}: swarm.{where}.{name}: no FLS node has this parameter (theirs: "
                f"{', '.join(known)}); another node's, such as the coordinator's "
                "round_timeout, goes in the ROS parameter file (params: FILE)"
            )
        if isinstance(spec.default, float) and type(value) is int:
            value = float(value)
        if type(value) is not type(spec.default):
            raise SwazureError(
                f"{path}: swarm.{where}.{name}: expected a {spec.type_name}, got {value!r}"
            )
        reason = spec.refuses(value)
        if reason is not None:
            raise SwazureError(f"{path}: swarm.{where}.{name} {reason}")
        checked[name] = value
    tracking = {
        name.removeprefix("track."): value
        for name, value in checked.items()
        if name in TRACK_SETTING_NAMES
    }
    try:
        TrackConfig(**tracking)  # checked together, as the node takes them
    except TrackingError as err:
        raise SwazureError(f"{path}: swarm.{where}.track: {err}") from None
    return checked


def example_swarms() -> list[str]:
    """The names of the example swarm files installed with the package (config/swarms/)."""
    return sorted(path.stem for path in (config_dir() / "swarms").glob("*.yaml"))


def swarm_file(text: str) -> Path:
    """A swarm file: a path, or the bare name of an example (``torus``, ``trio.yaml``).

    A path that exists wins; a bare name is looked up in the installed
    config/swarms/, so that it works from any folder, as ``ros2 launch`` is run.
    """
    given = Path(text).expanduser()
    if not given.exists() and given.name == text:
        stem = given.name.removesuffix(".yaml")
        example = config_dir() / "swarms" / f"{stem}.yaml"
        if example.is_file():
            return example
        if not given.suffix:
            raise argparse.ArgumentTypeError(
                f"{text}: no such file, nor an example swarm ({', '.join(example_swarms())})"
            )
    return arguments.input_file(str(given))


def add_swarm_file_argument(
    parser: argparse.ArgumentParser,
    help: str = "a swarm file, or an example's name (config/swarms/: torus, trio, grid25, ...): "
    "these options as YAML, with every FLS's and one FLS's ROS parameters; a flag given here "
    "overrides the file",
) -> None:
    """The optional swarm file of a verb; call after every option is added."""
    parser.add_argument(
        "swarm_file",
        nargs="?",
        type=swarm_file,
        default=None,
        metavar="SWARM_FILE",
        help=help,
    )
    # A flag left out takes the file's value, then the flag's own default.
    defaults = {key: parser.get_default(key) for key in CHECKS}
    parser.set_defaults(option_defaults=defaults, **dict.fromkeys(CHECKS))


def apply_swarm_file(args: argparse.Namespace) -> argparse.Namespace:
    """``args`` with every option left out taken from the swarm file, else its default.

    Adds ``parameters`` (every FLS node's) and ``fls_parameters`` (FLS id ->
    its own) from the file, empty without one.
    """
    from_file = load_swarm_file(args.swarm_file) if args.swarm_file is not None else {}
    given = {key for key in CHECKS if getattr(args, key) is not None}
    if given & {"beta", "radius"}:
        # The swarm's size on the command line replaces the file's, whichever it gave.
        from_file.pop("beta", None)
        from_file.pop("radius", None)
    merged = dict(vars(args))
    for key, default in args.option_defaults.items():
        if merged[key] is None:
            merged[key] = from_file[key] if from_file.get(key) is not None else default
    merged["parameters"] = from_file.get("parameters", {})
    merged["fls_parameters"] = from_file.get("fls", {})
    return argparse.Namespace(**merged)
