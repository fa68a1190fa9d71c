"""What every process and node of a swarm starts with: an rclpy context, and a lean node.

A process of a swarm owns one :class:`~rclpy.context.Context`
(:func:`init_context`), never the global one, so that tests and tools can
run several swarms side by side. Its nodes are :class:`SwarmNode`\\ s:
without a rosout publisher and the type description service, and with
parameter services only where asked, because each endpoint costs discovery
time in a swarm of thousands of nodes.
"""

from __future__ import annotations

import contextlib
import faulthandler
import gc
import itertools
import os
import signal
import subprocess
import sys
import threading
import traceback
from collections import Counter
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

import rclpy
from rcl_interfaces.msg import (
    ParameterDescriptor,
    ParameterEvent,
    ParameterType,
    SetParametersResult,
)

# The context every process owns; app/ names it through this module, not through rclpy.
from rclpy.context import Context as Context
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import qos_profile_parameter_events
from rclpy.service import Service
from rclpy.signals import SignalHandlerOptions
from rclpy.timer import Timer
from rclpy.utilities import remove_ros_args

from ...core.errors import SwazureError
from ...files.description import SwarmDescription
from ...files.reading import read_yaml
from .parameters import ParameterSpec, at_least, help_text, hex_digits


class ParameterError(SwazureError):
    """A node parameter with a value the node cannot run with."""


#: Off for every node of a swarm: the ``~/get_type_description`` service is two
#: more endpoints per node, and endpoints cost discovery time (docs/swarm.md).
#: Tools that need a type find it from the interface package instead.
NO_TYPE_DESCRIPTION_SERVICE = Parameter("start_type_description_service", value=False)


#: Where rclpy's nodes publish their parameter changes.
PARAMETER_EVENTS_TOPIC = "/parameter_events"


#: Seconds between two log lines of a callback that keeps failing.
FAILURE_LOG_EVERY = 5.0


class SwarmNode(Node):
    """A node of a swarm: no rosout, no type description service, parameter services if asked.

    A process that hosts one node (an FLS of its own, the world, the
    coordinator) turns its parameter services on, so that ``ros2 param``
    answers; a packed process of hundreds of FLSs leaves them off unless asked
    (``parameter_services``): they are six services a node (docs/swarm.md).
    """

    def __init__(
        self,
        name: str,
        *,
        namespace: str = "",
        context: Context | None = None,
        parameter_overrides: list[Parameter] | None = None,
        parameter_services: bool = False,
        parameter_events: Publisher | None = None,
    ) -> None:
        # Set before Node's constructor, which makes the events publisher (create_publisher).
        self._shared_parameter_events = parameter_events
        # Parameters a running node takes new values of: their specs and what applies them.
        self._live: dict[str, tuple[ParameterSpec, Callable[[Any], None]]] = {}
        #: Timer and service callbacks that raised, by where: counted, logged, never raised.
        self.failures: Counter[str] = Counter()
        super().__init__(
            name,
            namespace=namespace,
            context=context,
            parameter_overrides=[NO_TYPE_DESCRIPTION_SERVICE, *(parameter_overrides or [])],
            enable_rosout=False,
            start_parameter_services=parameter_services,
        )

    def create_publisher(self, msg_type: Any, topic: str, *args: Any, **kwargs: Any) -> Publisher:
        """Node's, but a node given ``parameter_events`` publishes its parameter events there.

        Every endpoint of a process makes rmw_fastrtps republish the process's
        whole entity list (docs/swarm.md): a packed process of thousands of FLS
        nodes shares its host's one /parameter_events writer instead of making
        one per node. The events say which node they are from, as before.
        """
        if topic == PARAMETER_EVENTS_TOPIC and self._shared_parameter_events is not None:
            return self._shared_parameter_events
        publisher: Publisher = super().create_publisher(msg_type, topic, *args, **kwargs)
        return publisher

    def create_timer(
        self, timer_period_sec: float, callback: Callable[[], Any], *args: Any, **kwargs: Any
    ) -> Timer:
        """Node's, with ``callback`` guarded: what it raises (a publish that DDS refuses, a
        defect of ours) is counted in :attr:`failures` and logged, never raised into the
        executor, which would end the process with every node in it."""
        name = getattr(callback, "__name__", "timer")

        def guarded() -> None:
            try:
                callback()
            except Exception as err:
                self._failed(f"timer {name}", err)

        timer: Timer = super().create_timer(timer_period_sec, guarded, *args, **kwargs)
        return timer

    def create_service(
        self, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any], **kwargs: Any
    ) -> Service:
        """Node's, with ``callback`` guarded: a request it fails on is answered with
        ``success: false`` and a one-line ``message`` (where the service has them),
        counted in :attr:`failures`; the node keeps serving."""

        def guarded(request: Any, response: Any) -> Any:
            try:
                return callback(request, response)
            except Exception as err:
                self._failed(f"service {srv_name}", err)
                if hasattr(response, "success") and hasattr(response, "message"):
                    response.success = False
                    response.message = f"internal error: {type(err).__name__}: {err}"
                return response

        service: Service = super().create_service(srv_type, srv_name, guarded, **kwargs)
        return service

    def _failed(self, where: str, err: Exception) -> None:
        self.failures[where] += 1
        self.get_logger().error(  # type: ignore[no-untyped-call]
            f"{where} failed ({self.failures[where]} so far): {type(err).__name__}: {err}",
            throttle_duration_sec=FAILURE_LOG_EVERY,
        )

    def create_parameter_events_publisher(self) -> Publisher:
        """A /parameter_events writer that packed nodes can share (``parameter_events``)."""
        return self.create_publisher(
            ParameterEvent, PARAMETER_EVENTS_TOPIC, qos_profile_parameter_events
        )

    def declare(self, spec: ParameterSpec, apply: Callable[[Any], None] | None = None) -> Any:
        """Declare ``spec``'s parameter and return its value; ParameterError if it is refused.

        With ``apply``, a value set while the node runs (``ros2 param set``) is
        checked by the spec's rule, refused with its reason, or handed to
        ``apply``; without, the parameter is read-only once declared.
        """
        descriptor = ParameterDescriptor(
            description=spec.description, read_only=apply is None, type=_TYPES[type(spec.default)]
        )
        try:
            value = self.declare_parameter(spec.name, spec.default, descriptor).value
        except ParameterException as err:
            raise ParameterError(f"{self.get_fully_qualified_name()}: {err}") from err
        reason = spec.refuses(value)
        if reason is not None:
            raise ParameterError(
                f"{self.get_fully_qualified_name()}: parameter {spec.name} {reason}"
            )
        if apply is not None:
            if not self._live:
                self.add_on_set_parameters_callback(self._check_set)
                self.add_post_set_parameters_callback(self._apply_set)
            self._live[spec.name] = (spec, apply)
        return value

    def _check_set(self, parameters: list[Parameter]) -> SetParametersResult:
        """Refuse a value set while the node runs that its spec's rule refuses, saying why."""
        for parameter in parameters:
            live = self._live.get(parameter.name)
            reason = live[0].refuses(parameter.value) if live is not None else None
            if reason is not None:
                return SetParametersResult(successful=False, reason=f"{parameter.name} {reason}")
        return SetParametersResult(successful=True)

    def _apply_set(self, parameters: list[Parameter]) -> None:
        for parameter in parameters:
            live = self._live.get(parameter.name)
            if live is not None:
                live[1](parameter.value)


#: The descriptor's type of a parameter, by its default's Python type.
_TYPES = {
    bool: ParameterType.PARAMETER_BOOL,
    int: ParameterType.PARAMETER_INTEGER,
    float: ParameterType.PARAMETER_DOUBLE,
    str: ParameterType.PARAMETER_STRING,
}


def check_params_file(path: Path) -> dict[str, dict[str, Any]]:
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


def init_context(domain_id: int | None = None, params_file: str | None = None) -> Context:
    """A fresh rclpy context on ``domain_id``, with a ROS 2 parameter file if given.

    Signals are left to the caller: a swarm stops between spins, not inside a callback.
    """
    args = []
    if params_file is not None:
        # Checked here so that a bad file gives our one line, not rcl's log lines too.
        check_params_file(Path(params_file))
        args = ["--ros-args", "--params-file", params_file]
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


#: Seconds a process's DDS teardown (:func:`exit_process`) may take before its watchdog
#: ends it (SIGKILL, a line in its log).
TEARDOWN_LIMIT = 30.0
#: The same for a :func:`run_process` program: one FLS, the world or the coordinator,
#: whose teardown takes about a second.
PROGRAM_TEARDOWN_LIMIT = 5.0
#: Seconds a :func:`run_process` program may take to reach its teardown once asked to
#: end before its watchdog ends it (exit code 1, every thread's stack in its log); with
#: the teardown's limit, under the launcher's grace (app.per_fls.STOP_GRACE), which
#: would kill it without a word.
STOP_LIMIT = 12.0


#: The watchdog of a process's teardown (:func:`exit_process`), a process of its own: it
#: waits ``limit`` s for the end of file of a pipe that only the ending process holds
#: open, and ends that process if it is still there.
TEARDOWN_WATCH = """
import os, select, signal, sys
pipe, pid, limit = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
if not select.select([pipe], [], [], limit)[0]:
    print(f"the DDS teardown did not end in {limit:g} s (a known Fast DDS deadlock): "
          "leaving without it", file=sys.stderr, flush=True)
    os.kill(pid, signal.SIGKILL)
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
    "Stopping"). A process still there ``limit`` s later is ended by its
    watchdog (TEARDOWN_WATCH: one line, then SIGKILL); its peers drop it when
    its DDS lease runs out.
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
         str(limit)],
        pass_fds=(watched,),
        stdin=subprocess.DEVNULL,
    )  # fmt: skip
    os.close(watched)
    alive = gc.get_objects()
    threading.Thread(target=_hold, args=(alive,), daemon=True).start()
    del alive
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
    do not run; its own streams are flushed.
    """
    _flush()
    os._exit(code)


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


def startup_arguments(values: dict[str, Any], specs: Sequence[ParameterSpec]) -> list[str]:
    """The program arguments that give ``specs``' parameters ``values``; a default is left out."""
    given = [spec for spec in specs if values.get(spec.name, spec.default) != spec.default]
    return [part for spec in given for part in (spec.option, str(values[spec.name]))]


def _startup_value(spec: ParameterSpec, text: str) -> Any:
    """``text`` as a value of ``spec``'s type; ParameterError if it is not one, or is refused."""
    option = spec.option
    kind = type(spec.default)
    try:
        if kind is bool:
            if text.lower() not in ("true", "false"):
                raise ValueError(text)
            value: Any = text.lower() == "true"
        else:
            value = kind(text)
    except ValueError:
        raise ParameterError(f"argument {option}: {text!r} is not a {spec.type_name}") from None
    reason = spec.refuses(value)
    if reason is not None:
        raise ParameterError(f"argument {option} {reason}")
    return value


def startup_parameters(given: Sequence[str], specs: Sequence[ParameterSpec]) -> dict[str, Any]:
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


def _names(parameters: dict[str, Any], prefix: str = "") -> list[str]:
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


def declare_startup(node: Node, values: dict[str, Any]) -> None:
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


def description_from(values: dict[str, Any]) -> SwarmDescription:
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


def description_parameters(description: SwarmDescription) -> dict[str, Any]:
    """The DESCRIPTION_PARAMETERS values of ``description``: what description_from reads."""
    return {
        "cloud": description.cloud,
        "scale": float(description.scale or 0.0),
        "beta": float(description.beta or 0.0),
        "radius": float(description.radius or 0.0),
        "sensor": description.sensor_file or "",
        "accurate": description.accurate,
        "seed": description.seed,
    }


def seconds_since_start() -> float:
    """Seconds since this process started (Linux: /proc), interpreter start-up included."""
    ticks = os.sysconf("SC_CLK_TCK")
    # Field 22 of /proc/self/stat, after the command name (which may hold spaces).
    started = int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[19]) / ticks
    return float(Path("/proc/uptime").read_text().split()[0]) - started


def program_startup(
    args: list[str] | None, usage: str, specs: Sequence[ParameterSpec]
) -> dict[str, Any]:
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


def run_process(
    build: Callable[[Context, dict[str, Any]], list[Node]],
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
    context = Context()
    rclpy.init(args=args, context=context, signal_handler_options=SignalHandlerOptions.NO)
    stop: list[int] = []

    def on_stop(number: int, frame: object) -> None:
        stop.append(number)
        # A process that has not ended this long after being asked prints every
        # thread's stack (to its log) and exits 1: a stop that hangs says where.
        faulthandler.dump_traceback_later(STOP_LIMIT, exit=True)

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, on_stop)
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
