"""A program's startup arguments: the facts a process needs before it can name or build its node.

They are program arguments before ``--ros-args`` (``--fls-id 7 --cloud
torus:120``: :attr:`~.parameters.ParameterSpec.option`), read by
:func:`program_startup` before any node or DDS participant exists; the node
built declares them read-only (:func:`declare_startup`). A ROS parameter
that names one is refused (:func:`refuse_startup_as_parameter`): rclpy would
take it silently as an override no node declares. A launcher writes them
with :func:`startup_arguments`.
"""

from __future__ import annotations

import itertools
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.utilities import remove_ros_args

from ...core.errors import SwazureError
from ...files.description import SwarmDescription
from ...files.reading import read_yaml
from .parameters import ParameterError, ParameterSpec, Value, at_least, help_text, hex_digits

#: A program's startup values, by parameter name.
StartupValues = dict[str, Value]

#: The parameters that describe a swarm (files.description.SwarmDescription), as every
#: process of a swarm in processes of its own takes them; 0 or "" means not given.
DESCRIPTION_PARAMETERS = (
    ParameterSpec(
        "cloud",
        "",
        "the swarm's point cloud: a file (.xyz .csv .npy .ply, cm after scale) "
        "or a built-in shape (torus:120); required",
    ),
    ParameterSpec(
        "scale",
        0.0,
        "multiply the cloud's coordinates by this to get cm; 0: the published "
        "scale of a published file, else 1",
    ),
    ParameterSpec("beta", 0.0, "FLS radius r = beta * dmin; 0: give radius instead"),
    ParameterSpec("radius", 0.0, "FLS radius r, cm; 0: give beta instead"),
    ParameterSpec("sensor", "", "sensor file (ranges, error model); '': config/sensor.yaml"),
    ParameterSpec("accurate", False, "measure without error"),
    ParameterSpec("seed", 0, "seed of the choice of colliding FLSs to remove", at_least(0)),
)
#: The swarm's namespace and key, as every program of a swarm takes them.
NAMESPACE = ParameterSpec("namespace", "swarm", "the swarm's namespace: nodes are /NAMESPACE/...")
KEY_FILE = ParameterSpec(
    "key_file", "", "the swarm's key (docs/security.md); '': $SWAZURE_SWARM_KEY_FILE, or none"
)
SWARM_INSTANCE = ParameterSpec(
    "swarm_instance",
    "",
    "the swarm instance inside every tag (32 hexadecimal digits; docs/security.md); '': the "
    "one the world node announces (the world program: a fresh one)",
    # security.auth.INSTANCE_BYTES (16) as hexadecimal digits.
    hex_digits(32),
)


def startup_arguments(values: Mapping[str, object], specs: Sequence[ParameterSpec]) -> list[str]:
    """The program arguments that give ``specs``' parameters ``values``; a default is left out.

    Each value is written as its text, which the program reads back by its spec's type
    (:func:`startup_parameters`).
    """
    given = [spec for spec in specs if values.get(spec.name, spec.default) != spec.default]
    return [part for spec in given for part in (spec.option, str(values[spec.name]))]


def _startup_value(spec: ParameterSpec, text: str) -> Value:
    """``text`` as a value of ``spec``'s type; ParameterError if it is not one, or is refused."""
    option = spec.option
    kind = type(spec.default)
    try:
        if kind is bool:
            if text.lower() not in ("true", "false"):
                raise ValueError(text)
            value: Value = text.lower() == "true"
        else:
            value = kind(text)
    except ValueError:
        raise ParameterError(f"argument {option}: {text!r} is not a {spec.type_name}") from None
    reason = spec.refuses(value)
    if reason is not None:
        raise ParameterError(f"argument {option} {reason}")
    return value


def startup_parameters(given: Sequence[str], specs: Sequence[ParameterSpec]) -> StartupValues:
    """The values of parameters a process needs before it can name or build its node.

    They are program arguments, before ``--ros-args`` (``--fls-id 7 --cloud
    torus:120``: ParameterSpec.option), so that no node, and no DDS
    participant, is made to read them (docs/swarm.md, "One process per FLS");
    the node built declares them read-only (:func:`declare_startup`).
    ParameterError for an unknown argument, a value of another type than its
    default's, or one its rule refuses.
    """
    by_option = {spec.option: spec for spec in specs}
    values = {spec.name: spec.default for spec in specs}
    words = list(given)
    while words:
        option, has_value, text = words.pop(0).partition("=")
        spec = by_option.get(option)
        if spec is None:
            raise ParameterError(
                f"unknown argument {option!r}: give the startup arguments before --ros-args, "
                "the node's parameters after it as -p NAME:=VALUE (--help lists them)"
            )
        if not has_value:
            if not words:
                raise ParameterError(f"argument {option}: a value is needed")
            text = words.pop(0)
        values[spec.name] = _startup_value(spec, text)
    return values


#: The ROS arguments (rcl's) that set one parameter, and that name a parameter file.
PARAMETER_FLAGS = ("-p", "--param")
PARAMETERS_FILE_FLAG = "--params-file"


def ros_arguments(argv: Sequence[str]) -> list[str]:
    """The words of ``argv``'s ``--ros-args`` blocks (each to a ``--`` or to the end)."""
    words, inside = [], False
    for word in argv:
        if word == "--ros-args":
            inside = True
        elif inside and word == "--":
            inside = False
        elif inside:
            words.append(word)
    return words


def check_params_file(path: Path) -> dict[str, dict[str, object]]:
    """The sections of ROS 2 parameter file ``path`` (node: ros__parameters: ...), each
    node's parameters; SwazureError unless it is one (a regular file, small: read_yaml)."""
    document = read_yaml(path, "ROS 2 parameter", SwazureError)
    if not isinstance(document, dict) or not all(
        isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict)
        for section in document.values()
    ):
        raise SwazureError(
            f"{path}: not a ROS 2 parameter file: expect NODE: {{ros__parameters: {{...}}}}"
        )
    return {str(node): section["ros__parameters"] for node, section in document.items()}


def _names(parameters: Mapping[str, object], prefix: str = "") -> list[str]:
    """The parameter names of a ``ros__parameters`` mapping, nested ones joined by dots."""
    names = []
    for name, value in parameters.items():
        if isinstance(value, dict):
            names += _names(value, f"{prefix}{name}.")
        else:
            names.append(f"{prefix}{name}")
    return names


def refuse_startup_as_parameter(argv: Sequence[str], specs: Sequence[ParameterSpec]) -> None:
    """ParameterError if the ROS arguments of ``argv`` set a startup parameter of ``specs``.

    rclpy would take ``-p swarm_instance:=...`` (or the name in a ``--params-file``)
    as a parameter override that no node declares, and say nothing: the
    program would run without it (issue 66: then wait 60 s for an instance).
    Each parameter file is checked here too (check_params_file: a regular file
    of ROS 2 parameters), before rcl reads it.
    """
    by_name = {spec.name: spec for spec in specs}
    words = ros_arguments(argv)
    for flag, word in itertools.pairwise(words):
        if flag in PARAMETER_FLAGS:
            # NAME:=VALUE, or NODE:NAME:=VALUE for one node.
            target, _, value = word.partition(":=")
            spec = by_name.get(target.rpartition(":")[2])
            if spec is not None:
                raise ParameterError(
                    f"{flag} {word}: {spec.name} is not a node parameter but this program's "
                    f"argument: give {spec.option} {value or 'VALUE'} before --ros-args"
                )
        elif flag == PARAMETERS_FILE_FLAG:
            for node, parameters in check_params_file(Path(word)).items():
                found = [by_name[name] for name in _names(parameters) if name in by_name]
                if found:
                    raise ParameterError(
                        f"{word}: {node}: {found[0].name} is not a node parameter but this "
                        f"program's argument: give {found[0].option} VALUE before --ros-args"
                    )


def declare_startup(node: Node, values: StartupValues) -> None:
    """Declare on ``node`` the startup parameters it was built from, read-only.

    ``ros2 param get`` then shows what the node was started with; changing them
    would need a new node.
    """
    for name, value in values.items():
        if not node.has_parameter(name):
            node.declare_parameter(
                name,
                value,
                ParameterDescriptor(description="set at start (read-only)", read_only=True),
                # What the node was built from, whatever a parameter file says of the name.
                ignore_override=True,
            )


def description_from(values: Mapping[str, Value]) -> SwarmDescription:
    """The swarm's description from DESCRIPTION_PARAMETERS values; ParameterError if no cloud."""
    if not values["cloud"]:
        raise ParameterError(
            "parameter cloud: the swarm's point cloud (a file or shape:N) is needed"
        )
    return SwarmDescription(
        cloud=str(values["cloud"]),
        scale=float(values["scale"]) or None,
        beta=float(values["beta"]) or None,
        radius=float(values["radius"]) or None,
        sensor_file=str(values["sensor"]) or None,
        accurate=bool(values["accurate"]),
        seed=int(values["seed"]),
    )


def description_parameters(description: SwarmDescription) -> StartupValues:
    """The DESCRIPTION_PARAMETERS values of ``description``: what description_from reads.

    A resampled cloud is given as the file the launcher wrote it to
    (``SwarmDescription.written``), in cm: every process reads the same points.
    """
    if description.resample is not None and description.resampled_file is None:
        raise ValueError("a resampled cloud is given to a process once written: written(folder)")
    resampled = description.resampled_file
    return {
        "cloud": description.cloud if resampled is None else resampled,
        "scale": float(description.scale or 0.0) if resampled is None else 1.0,
        "beta": float(description.beta or 0.0),
        "radius": float(description.radius or 0.0),
        "sensor": description.sensor_file or "",
        "accurate": description.accurate,
        "seed": description.seed,
    }


def program_startup(
    args: list[str] | None, usage: str, specs: Sequence[ParameterSpec]
) -> StartupValues:
    """A program's startup values from its arguments before ``--ros-args``
    (:func:`startup_parameters`); ``--help`` prints ``usage`` (exit 0), a bad
    argument one line (exit 2)."""
    argv = sys.argv if args is None else args
    try:
        # Before rcl parses the arguments: it reads each parameter file as it does.
        refuse_startup_as_parameter(argv, specs)
        given = remove_ros_args(argv)[1:]
        if given in (["-h"], ["--help"]):
            print(usage)
            sys.exit(0)
        return startup_parameters(given, specs)
    except SwazureError as err:  # ParameterError, or a parameter file that is not one
        print(f"error: {err}", file=sys.stderr)
    except RuntimeError as err:  # rcl's RCLInvalidROSArgsError: one line, not its stack
        print(f"error: the ROS arguments: {str(err).split(', at /')[0]}", file=sys.stderr)
    sys.exit(2)


def program_help(
    program: str,
    about: str,
    startup: Sequence[ParameterSpec],
    parameters: Sequence[ParameterSpec] = (),
) -> str:
    """The ``--help`` of ``ros2 run swazure_ros PROGRAM``."""
    usage = (
        f"ros2 run swazure_ros {program} [--help] [--NAME VALUE ...] "
        "[--ros-args -p NAME:=VALUE ...]"
    )
    return help_text(usage, about, parameters, startup)
