"""The ROS parameters of an FLS node, as specs, without rclpy.

The node declares them (:class:`~.fls_node.FlsNode`, :class:`~.fls_tracking.FlsTracking`,
the ``fls`` program's radio join), the ``fls`` program's ``--help`` lists them, and a
swarm file's ``parameters:`` and ``fls:`` are checked against them when the file is
read (:func:`checked_parameters`, from ``app.config.load_swarm_file``), by verbs that start
no node and load no rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, cast

from ...core.estimators import TrackingError
from ...core.tracking import TRACK_SETTINGS, TrackConfig
from ...files.swarm_file import NodeParameters, ParameterValue
from ..plumbing.parameters import ParameterSpec, at_least, seconds

PUBLISH_PERIOD = ParameterSpec(
    "publish_period",
    1.0,
    "s between camera frames: a changed measurement is sent (> 0; set while running too)",
    seconds(),
)
REPUBLISH_PERIOD = ParameterSpec(
    "republish_period",
    0.0,
    "s after which an unchanged measurement is sent again; 0: never (set while running too)",
    seconds(allow_zero=True),
)
CAMERA_VIEW = ParameterSpec(
    "camera_view",
    -1,
    "id of a neighbour: publish what this FLS's camera sees aimed at its marker on "
    "~/camera/image_raw and ~/camera/camera_info; -1: none",
    at_least(-1),
)
#: The parameters every FLS node declares, besides its tracking's.
NODE = (PUBLISH_PERIOD, REPUBLISH_PERIOD, CAMERA_VIEW)

TRACK_SERVICE_FLAG = ParameterSpec(
    "track.service", False, "offer ~/track: this FLS follows a moving target on request"
)
REPORT_PROGRESS = ParameterSpec(
    "track.report_progress",
    False,
    "publish track_progress after each track event: for a driver of a simulated clock "
    "across processes (swazure track --per-fls)",
)
TRACK_PEERS = ParameterSpec(
    "track.peers",
    0,
    "with track.report_progress: FLS processes taking part in the run, this one included; "
    "its first report waits until its track publishers have matched that many readers",
    at_least(0),
)
#: track.<name>, defaulting to TrackConfig's (TrackConfig checks them together).
TRACK_SETTINGS_SPECS = tuple(
    ParameterSpec(f"track.{name}", getattr(TrackConfig(), name), description)
    for name, description in TRACK_SETTINGS.items()
)
#: The parameters an FLS node's tracking declares.
TRACKING = (TRACK_SERVICE_FLAG, REPORT_PROGRESS, TRACK_PEERS, *TRACK_SETTINGS_SPECS)

JOIN_TIMEOUT = ParameterSpec(
    "join_timeout",
    30.0,
    "s after its first frame that an FLS waits to be heard by every FLS before it takes part "
    "in rounds anyway",
    seconds(),
)
#: Every parameter an FLS node may declare: JOIN_TIMEOUT is a standalone FLS's (the ``fls``
#: program's, one FLS to a process).
EVERY = (*NODE, *TRACKING, JOIN_TIMEOUT)
#: What every rclpy node declares itself: the simulated clock's switch.
RCLPY_OWN = ParameterSpec("use_sim_time", False, "run on /clock (a simulated clock)")


def checked_parameters(given: Mapping[str, ParameterValue]) -> NodeParameters:
    """``given`` ROS parameters, each one an FLS node has, of its type, by its rule.

    A name no FLS node declares would be ignored by every node without a word
    (the coordinator's ``round_timeout`` among them): it is refused. A whole
    number where the parameter is a double is taken as that double, as the flag
    would take it (rclpy refuses an integer for a double). The ``track.*``
    settings are checked together, as the node takes them (TrackConfig).

    Raises
    ------
    ValueError
        In one line that begins with the refused parameter's name (``publish_period
        must be ...``), or with ``track:`` for settings refused together.
    """
    specs = {spec.name: spec for spec in (*EVERY, RCLPY_OWN)}
    checked: NodeParameters = {}
    for name, value in given.items():
        spec = specs.get(name)
        if spec is None:
            known = [other for other in specs if not other.startswith("track.")] + ["track.*"]
            raise ValueError(
                f"{name}: no FLS node has this parameter (theirs: {', '.join(known)}); "
                "another node's, such as the coordinator's round_timeout, goes in the ROS "
                "parameter file (params: FILE)"
            )
        if isinstance(spec.default, float) and type(value) is int:
            value = float(value)
        # Every FLS parameter is a scalar, of its default's type.
        if isinstance(value, list) or type(value) is not type(spec.default):
            raise ValueError(f"{name}: expected a {spec.type_name}, got {value!r}")
        reason = spec.refuses(value)
        if reason is not None:
            raise ValueError(f"{name} {reason}")
        checked[name] = value
    tracking = {
        name.removeprefix("track."): value
        for name, value in checked.items()
        if name.startswith("track.") and name.removeprefix("track.") in TRACK_SETTINGS
    }
    try:
        # Each of its spec's type, checked above: TrackConfig checks them together.
        TrackConfig(**cast(Mapping[str, Any], tracking))
    except TrackingError as err:
        raise ValueError(f"track: {err}") from None
    return checked
