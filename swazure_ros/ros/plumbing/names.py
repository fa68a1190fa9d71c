"""Every name, QoS profile and wire code of the swarm's ROS interface, in one place.

Names are relative to the swarm's namespace (``/swarm`` by default) unless
they start with ``/``; per-FLS services are under ``fls_<id>/``. Wire codes
map the message constants (swazure_interfaces) to the core's and the
protocol's names; where the protocol keeps numbers of its own they equal the
message constants, which the tests check.
"""

from __future__ import annotations

from collections.abc import Sequence

from rclpy.exceptions import InvalidNamespaceException, InvalidTopicNameException
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.validate_full_topic_name import validate_full_topic_name
from rclpy.validate_namespace import validate_namespace
from swazure_interfaces.msg import DiscoveryControl, TrackEstimate

from ...core.arrays import IntArray
from ...core.estimators import CONSTANT_ACCELERATION, CONSTANT_VELOCITY
from ...core.fit import LOCAL_LEAST_SQUARES, PATH, SWARM_FIT
from ...core.paths import FEWEST_HOPS, LEAST_ERROR, SHORTEST_LENGTH, check_policy
from ...core.tracking import ENDED, TIMED_OUT, TRACKING, WAITING
from ...protocol.cells import cell_name

# Topics, shared by every FLS: a reader filters on the FLS id in the message.
# Per-FLS topics would buy nothing, and every endpoint costs discovery time
# in a swarm of thousands (docs/swarm.md).
MEASUREMENTS_TOPIC = "measurements"
#: The offers' topics are per band and radio cell (radio_topic): ``radio/sweet/c<i>_<j>_<k>``.
RADIO_TOPIC = "radio"
ESTIMATES_TOPIC = "estimates"
CONTROL_TOPIC = "discovery"
ACK_TOPIC = "round_acks"
WALKS_TOPIC = "path_walks"
WORLD_TOPIC = "world"
MOVE_TOPIC = "move_commands"
TRACK_REQUESTS_TOPIC = "track_requests"
TRACK_SAMPLES_TOPIC = "track_samples"
TRACK_ESTIMATES_TOPIC = "track_estimates"
TRACK_PROGRESS_TOPIC = "track_progress"
DEPARTED_TOPIC = "departed"
#: Each process's radio says it is alive (swazure_interfaces/Heartbeat; docs/protocol.md).
HEARTBEAT_TOPIC = "heartbeats"
#: The swarm instance, announced by the world node (swazure_interfaces/SwarmInstance).
INSTANCE_TOPIC = "swarm_instance"
#: The swarm as RViz markers (view node), and the Foxglove channel of the same scene.
SCENE_TOPIC = "scene"
#: tf2's topic of fixed frames, global by convention (not under the swarm's namespace):
#: ``swarm`` -> ``fls_<id>``, republished at each world revision.
TF_STATIC_TOPIC = "/tf_static"
#: cm from the origin beyond which no FLS position or move is taken from the network:
#: a display is metres across, and far-off coordinates overflow the geometry.
WORLD_REACH = 1e6
#: Seconds a node must stay off the ROS graph before it counts as gone.
LIVENESS_GRACE = 2.0
#: Per FLS, when its camera_view parameter names a neighbour: what its camera sees.
CAMERA_IMAGE_TOPIC = "camera/image_raw"
CAMERA_INFO_TOPIC = "camera/camera_info"
#: An FLS's own camera's readings (swazure_interfaces/Detections), relative to its node.
DETECTIONS_TOPIC = "camera/detections"
CLOCK_TOPIC = "/clock"

# Services: each FLS answers for itself (fls_<id>/...), the coordinator for the swarm.
NEIGHBOURS_SERVICE = "get_neighbours"
COMPUTE_POSE_SERVICE = "compute_pose"
TRACK_SERVICE = "track"
COORDINATOR = "coordinator"
WORLD = "world"
#: The simulated cameras of FLSs that run one to a process (ros.nodes.world_node).
CAMERAS = "cameras"


def radio_topic(band: str, cell: Sequence[int] | IntArray) -> str:
    """The topic of the offers sent in radio cell ``cell`` of ``band`` (``protocol.cells``)."""
    return f"{RADIO_TOPIC}/{band}/{cell_name(cell)}"


def walks_topic(cell: Sequence[int] | IntArray) -> str:
    """The topic of the path walks FLSs in cell ``cell`` of the decaying band send on."""
    return f"{WALKS_TOPIC}/{cell_name(cell)}"


#: The node name the ROS graph gives an endpoint whose participant's node names have not
#: arrived yet (rmw_dds_common's graph cache).
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"


def node_name(fls_id: int) -> str:
    """The node name of FLS ``fls_id``."""
    return f"fls_{fls_id}"


def fls_id_of(name: str) -> int | None:
    """The FLS id of node name ``name`` (``fls_12`` -> 12), or None for another node."""
    prefix, _, digits = name.partition("_")
    return int(digits) if prefix == "fls" and digits.isdigit() else None


def host_name(index: int) -> str:
    """The node name of the host node of process ``index``."""
    return f"host_{index}"


# What an FLS measures changes only when the world does, so an FLS publishes a
# measurement when it changes, and the last one stays for readers who come later
# (latched: transient local, one per FLS), as a map or a robot description does.
MEASUREMENTS_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
# A radio hears every FLS's latched measurements at once (a fitting run's windows):
# it keeps them all until its callbacks have taken them.
READINGS_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
# A camera's last frame of detections is what the FLS sees until the next one: an
# FLS that starts later must get it at once (latched, like measurements).
DETECTIONS_QOS = MEASUREMENTS_QOS
# A round brings one message from every FLS at once: readers must keep them all,
# and a lost label would change a path, so delivery is reliable.
ROUND_QOS = QoSProfile(
    depth=1, history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE
)
# Every command of a move group counts: a lost one would hold the group for ever.
MOVE_QOS = ROUND_QOS
# The world's newest revision is state: a process that joins late must get it.
WORLD_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
# tf2's static frames, as tf2_ros's StaticTransformBroadcaster offers them: latched.
TF_STATIC_QOS = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)
# Who is gone is state, like the world: a reader that comes later gets the list.
DEPARTED_QOS = WORLD_QOS
# Whether a radio hears the controls is state too: each radio's last beat is latched, so
# that a coordinator whose reader matches late (or a restarted one) gets it. The reader
# keeps every beat until taken: a hundred radios' latched beats come at once.
HEARTBEAT_QOS = MEASUREMENTS_QOS
HEARTBEATS_READ_QOS = READINGS_QOS
INSTANCE_QOS = WORLD_QOS
# So is the scene: RViz started later draws the current one.
SCENE_QOS = WORLD_QOS
# The simulated clock is driven tick by tick and re-published while a tick is
# outstanding (app.track), so every tick must arrive: reliable, a few deep.
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)

#: DiscoveryControl.POLICY_* (and ComputePose's) -> the core's policy names.
POLICY_NAMES = {
    DiscoveryControl.POLICY_FEWEST_HOPS: FEWEST_HOPS,
    DiscoveryControl.POLICY_SHORTEST_LENGTH: SHORTEST_LENGTH,
    DiscoveryControl.POLICY_LEAST_ERROR: LEAST_ERROR,
}
POLICY_CODES = {name: code for code, name in POLICY_NAMES.items()}

#: DiscoveryControl.ESTIMATOR_* (and ComputePose's, PoseEstimate's) -> the core's estimators.
ESTIMATOR_NAMES = {
    DiscoveryControl.ESTIMATOR_PATH: PATH,
    DiscoveryControl.ESTIMATOR_LOCAL_LEAST_SQUARES: LOCAL_LEAST_SQUARES,
    DiscoveryControl.ESTIMATOR_SWARM_FIT: SWARM_FIT,
}
ESTIMATOR_CODES = {name: code for code, name in ESTIMATOR_NAMES.items()}

#: TrackEstimate.MODEL_* (and TrackTarget's) -> the core's filter models.
TRACK_MODEL_NAMES = {
    TrackEstimate.MODEL_CONSTANT_VELOCITY: CONSTANT_VELOCITY,
    TrackEstimate.MODEL_CONSTANT_ACCELERATION: CONSTANT_ACCELERATION,
}
TRACK_MODEL_CODES = {name: code for code, name in TRACK_MODEL_NAMES.items()}

#: TrackEstimate.STATUS_* -> the core's stream states.
TRACK_STATE_NAMES = {
    TrackEstimate.STATUS_WAITING: WAITING,
    TrackEstimate.STATUS_TRACKING: TRACKING,
    TrackEstimate.STATUS_ENDED: ENDED,
    TrackEstimate.STATUS_TIMED_OUT: TIMED_OUT,
}
TRACK_STATE_CODES = {name: code for code, name in TRACK_STATE_NAMES.items()}


def policy_code(policy: str) -> int:
    """The ComputePose / DiscoveryControl code of a policy name (ValueError if unknown)."""
    code: int = POLICY_CODES[check_policy(policy)]
    return code


def namespace_problem(namespace: str) -> str | None:
    """Why ``namespace`` (absolute) is not a ROS namespace, in rclpy's words; None if it is."""
    try:
        validate_namespace(namespace)
    except InvalidNamespaceException as err:
        return _reason(err)
    return None


def checked_namespace(text: str) -> str:
    """``text`` as a ROS namespace without its leading slash (``swarm``, ``show/left``);
    ValueError in one line, the command line's and the swarm file's, when it is not one."""
    name = text.strip("/")
    if not name:
        raise ValueError("a namespace needs a name (e.g. swarm)")
    reason = namespace_problem(f"/{name}")
    if reason is not None:
        raise ValueError(
            f"{text!r} is not a ROS namespace ({reason}; use letters, digits, _ and /)"
        )
    return name


def topic_problem(topic: str) -> str | None:
    """Why ``topic`` is not a fully qualified ROS topic name, in rclpy's words; None if it is."""
    try:
        validate_full_topic_name(topic)
    except InvalidTopicNameException as err:
        return _reason(err)
    return None


def _reason(err: Exception) -> str:
    """rclpy's reason, without the lines that point at the name with a caret."""
    return str(err).splitlines()[0].split(": ", 1)[-1].rstrip(":")
