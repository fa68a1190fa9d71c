"""The ``fls`` program: one FLS in its own process, as on FLS hardware.

``ros2 run swazure_ros fls --fls-id 7 --cloud torus:120 --beta 0.5``

The FLS senses by its camera's detections (``fls_<id>/camera/detections``)
and has a radio of its own (:class:`.radio.Radio`). It joins the swarm's rounds
only once every FLS and the coordinator hear it (:class:`RadioJoin`).
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
import time
from functools import partial

from rclpy.context import Context
from rclpy.node import Node
from rclpy.timer import Timer

from ...core.errors import SwazureError
from ...core.relay import RelaySenses, moving_senses
from ...files.trajectories import parse_motion
from ...protocol.senses import DetectedSenses
from ..nodes import fls_parameters
from ..nodes.fls_camera import DetectedSensing
from ..nodes.fls_node import FlsNode, RadioLink
from ..nodes.fls_parameters import JOIN_TIMEOUT
from ..nodes.instance import program_key
from ..nodes.radio import Radio
from ..plumbing.lease import participant_lease
from ..plumbing.names import DETECTIONS_TOPIC
from ..plumbing.parameters import ParameterError, ParameterSpec
from ..plumbing.process import Continues, catch_continues, run_process
from ..plumbing.startup import (
    DESCRIPTION_PARAMETERS,
    KEY_FILE,
    NAMESPACE,
    SWARM_INSTANCE,
    StartupValues,
    declare_startup,
    description_from,
    program_help,
)

#: Seconds between two looks of a standalone FLS at whether every FLS hears it yet.
JOIN_POLL = 0.1
#: Seconds between two lines of a standalone FLS that still waits to be heard.
WAITING_SAID_EVERY = 5.0
#: In the environment of an FLS program that started itself afresh: how many times it has.
STARTED_AFRESH = "SWAZURE_STARTED_AFRESH"


FLS_ID = ParameterSpec("fls_id", -1, "this FLS's id: its row in the swarm's point cloud; required")
TRACK_MOTION = ParameterSpec(
    "track.motion", "", "a simulated track run's motion of every FLS (swazure track --per-fls)"
)
#: What the program takes as arguments, before it builds its node.
STARTUP = (FLS_ID, NAMESPACE, KEY_FILE, SWARM_INSTANCE, TRACK_MOTION, *DESCRIPTION_PARAMETERS)
USAGE = program_help(
    "fls",
    """One FLS in its own process, as on FLS hardware. It senses by its camera's detections
(~/camera/detections: from `ros2 run swazure_ros world`, the simulator, or an
aruco_detector on a real camera) and takes part in the swarm's discovery runs once
the coordinator (`ros2 run swazure_ros coordinator`) and every FLS hear it.

  ros2 run swazure_ros fls --fls-id 7 --cloud torus:120 --scale 5 --beta 0.5""",
    STARTUP,
    fls_parameters.EVERY,
)


class RadioJoin:
    """A standalone FLS's radio: made at its camera's first frame, listening once heard.

    The swarm's rounds count an FLS once it hears the controls
    (``Coordinator.hosts_matched``). Before its camera's first frame it would
    answer every round as an FLS that sees no one, and the swarm would find
    fewer paths than there are: the radio is made then. Its offers must reach
    every FLS's radio and the coordinator, its acks and estimates the
    coordinator, before a round counts on it: a round sent to an FLS whose
    writers are not matched yet waits a round timeout for it. Only this FLS
    sees its own writers matched, so it listens once they are, or after
    ``join_timeout`` seconds. ``continues``: the process's stops it went on from, which
    tell its heartbeats a stop from starving.
    """

    def __init__(self, node: FlsNode, sensing: DetectedSensing, continues: Continues) -> None:
        self.node = node
        self.sensing = sensing
        self.continues = continues
        self.senses = sensing.senses
        self.radio: Radio | None = None
        self.made_at = float("nan")
        self.join_timeout = node.declare(JOIN_TIMEOUT)
        self.poll: Timer = node.create_timer(JOIN_POLL, self.listen_when_heard)
        self.senses.on_revision.insert(0, self.make_radio)
        self._said_at = time.monotonic()
        # A person who started one FLS by hand sees what it waits for.
        detections = f"{node.get_fully_qualified_name()}/{DETECTIONS_TOPIC}"
        node.get_logger().info(  # type: ignore[no-untyped-call]
            f"waiting for its camera's first frame on {detections} (from the simulator, "
            "`ros2 run swazure_ros world`, or an aruco_detector on a camera)"
        )

    def make_radio(self) -> None:
        """Make the radio at the camera's first frame (later frames find it made)."""
        if self.radio is not None:
            return
        node = self.node
        self.radio = Radio(
            node,
            self.senses,
            {node.fls_id: node},
            guard=self.sensing.guard,
            listen=False,
            readings=node.discovery.readings,
        )
        # Stalled for longer than its peers wait for its announcements, it starts afresh.
        silence = participant_lease().silence
        self.radio.heartbeats.when_stalled(
            silence, partial(start_afresh, node), self.continues.went_on
        )
        self.made_at = time.monotonic()
        node.get_logger().info(  # type: ignore[no-untyped-call]
            "radio on: its camera's first frame is in; waiting to be heard by every FLS and "
            "the coordinator (`ros2 run swazure_ros coordinator`)"
        )

    def listen_when_heard(self) -> None:
        """Listen once every FLS's radio and the coordinator hear this FLS, or at the timeout."""
        if self.radio is None:
            return
        # Every FLS within one radio cell of this one (itself included) hears its cell.
        readers, wanted = self.radio.cell_readers()
        estimates = self.node.transmitter.readers()
        heard = readers >= wanted and estimates >= 1 and self.radio.ack_readers() >= 1
        now = time.monotonic()
        waited = now - self.made_at
        if not heard and now - self._said_at >= WAITING_SAID_EVERY:
            self._said_at = now
            self.node.get_logger().info(  # type: ignore[no-untyped-call]
                f"still waiting to be heard: {readers} of the {wanted} readers its radio cells "
                f"want, coordinator {'yes' if estimates >= 1 else 'not yet'}"
            )
        if heard or waited > self.join_timeout:
            self.radio.listen()
            how = (
                "heard by every FLS in its radio cells and the coordinator"
                if heard
                else (
                    f"after {waited:.0f} s, heard by {readers} of the {wanted} readers its "
                    "radio cells want"
                )
            )
            self.node.get_logger().info(f"on the swarm's radio: {how}")  # type: ignore[no-untyped-call]
            self.node.destroy_timer(self.poll)


def start_afresh(node: Node, late: float) -> None:
    """Start this program again in this process: a new DDS participant, as if started anew.

    Its executor stood still for ``late`` s, its CPU idle and its threads not
    waiting for a CPU (stopped: ``protocol.pulse``): longer than its peers wait for
    its announcements, so they have dropped its participant. Going on with it, its
    peers' graph would not show its node again, and some of its endpoints would not
    be matched again (docs/protocol.md, "Coming back"). A process started afresh is a new
    participant (Fast DDS gives each a new random GUID prefix) that comes up
    as at bring-up and is taken back as an FLS started again is. It keeps its
    pid, its log and the launcher's pipe (``app.per_fls.FLS_PROGRAM``); the old
    participant is not torn down, which its peers no longer hear anyway (and
    a teardown while peers come and go is where Fast DDS deadlocks, #6502).
    """
    count = int(os.environ.get(STARTED_AFRESH, "0") or 0) + 1
    node.get_logger().warning(
        f"its executor stood still for {late:.1f} s, its CPU idle: its peers have dropped it; "
        f"starting afresh ({count} so far)"
    )
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    close_on_exec_all_but_pipes()
    os.execve(sys.executable, sys.orig_argv, {**os.environ, STARTED_AFRESH: str(count)})


def close_on_exec_all_but_pipes() -> None:
    """Have an exec close every descriptor but the standard three and pipes.

    Fast DDS opens its sockets and shared-memory locks without close-on-exec:
    a program started afresh would hold the old participant's (8 sockets, its
    ports). A pipe is what a launcher gave the process to keep
    (``app.per_fls.FLS_PROGRAM``'s, whose end of file stops the FLS).
    """
    for name in os.listdir("/proc/self/fd"):
        with contextlib.suppress(OSError):  # the listing's own, closed by now
            fd = int(name)
            if fd > 2 and not stat.S_ISFIFO(os.fstat(fd).st_mode):
                os.set_inheritable(fd, False)


def build_fls(context: Context, values: StartupValues) -> list[Node]:
    """One FLS in its own process: it senses by its camera's detections, radio of its own.

    ``values`` (STARTUP): ``fls_id``, the swarm's description (``cloud``,
    ``beta`` or ``radius``, ``scale``, ``sensor``, ``seed``, ``accurate``),
    ``namespace`` and ``key_file`` (the swarm's key; "" for none, and then
    ``SWAZURE_SWARM_KEY_FILE`` if set); the FLS node's own are parameters.
    """
    fls_id = values["fls_id"]
    if isinstance(fls_id, bool) or not isinstance(fls_id, int) or fls_id < 0:
        raise ParameterError(f"argument --fls-id: an FLS id (>= 0) is needed, got {fls_id!r}")
    description = description_from(values)
    assigned = description.assigned()
    senses = DetectedSenses(
        fls_id, assigned.cloud_index, assigned.points, description.sensor(), assigned.radius
    )
    key = program_key(context, values)
    relay_senses = None
    if values["track.motion"]:
        # A simulated track run's relay camera (swazure track --per-fls): the motion
        # the run gives every FLS, as the packed swarm's replica senses it.
        try:
            motion = parse_motion(str(values["track.motion"]))
        except SwazureError as err:
            raise ParameterError(f"argument --track-motion: {err}") from err
        moving = moving_senses(
            senses.sensor, senses.radius, assigned.cloud_index, assigned.points, motion
        )

        def relay_senses() -> RelaySenses:
            return moving

    node = FlsNode(
        fls_id,
        senses,
        namespace=str(values["namespace"]),
        context=context,
        link=RadioLink(key=key),
        camera=senses,
        relay_senses=relay_senses,
        parameter_services=True,
    )
    assert node.detected is not None  # it senses by its camera's detections
    node.offer_neighbours_service()  # alone in its process: no host answers for it
    RadioJoin(node, node.detected, catch_continues())
    declare_startup(node, values)
    return [node]


def main(args: list[str] | None = None) -> int:
    """``ros2 run swazure_ros fls --fls-id 7 --cloud torus:120 --beta 0.5``."""
    return run_process(build_fls, args, usage=USAGE, startup=STARTUP)
