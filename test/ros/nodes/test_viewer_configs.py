"""The RViz config and the Foxglove layout that ship open on what the swarm publishes.

Neither RViz nor Foxglove runs here: the files are parsed (YAML, JSON), and every
topic and frame they name is checked against the product's own names (ros.plumbing.names,
core.frames, the default namespace) and, for the scene, against a real view node's
publisher on the graph: its type and the QoS RViz must ask for to get a latched scene.
"""

from __future__ import annotations

import json
from dataclasses import fields

import numpy as np
import pytest
import yaml
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

from swazure_ros.app.config import SwarmConfig
from swazure_ros.core.frames import SWARM_FRAME
from swazure_ros.ros.convert.markers import scene_markers
from swazure_ros.ros.nodes.view import ViewNode
from swazure_ros.ros.plumbing import names
from swazure_ros.ros.plumbing.node import SwarmNode
from swazure_ros.view.scene import Polyline, Scene

from ...conftest import REPO
from ...waits import PATIENCE, wait_until

RVIZ = REPO / "config" / "rviz" / "swarm.rviz"
FOXGLOVE = REPO / "config" / "foxglove" / "swarm.json"
#: The swarm's namespace when none is given (spawn, launch files, swarm files).
NAMESPACE = next(f.default for f in fields(SwarmConfig) if f.name == "namespace")
#: RViz's names of the QoS policies, as its Topic property writes them.
RVIZ_DURABILITY = {
    DurabilityPolicy.TRANSIENT_LOCAL: "Transient Local",
    DurabilityPolicy.VOLATILE: "Volatile",
}
RVIZ_RELIABILITY = {
    ReliabilityPolicy.RELIABLE: "Reliable",
    ReliabilityPolicy.BEST_EFFORT: "Best Effort",
}
#: What each display class of the RViz config draws: the message type of its topic.
RVIZ_TYPES = {"rviz_default_plugins/MarkerArray": "visualization_msgs/msg/MarkerArray"}


def product_topics() -> set[str]:
    """Every topic named in ros.plumbing.names, resolved in the default namespace."""
    topics = {value for key, value in vars(names).items() if key.endswith("_TOPIC")}
    return {t if t.startswith("/") else f"/{NAMESPACE}/{t}" for t in topics}


def rviz_displays(config: dict) -> list[dict]:
    """The displays of an RViz config, groups opened."""
    found, pending = [], list(config["Visualization Manager"]["Displays"])
    while pending:
        display = pending.pop()
        found.append(display)
        pending += display.get("Displays", [])
    return found


def rviz_topics(config: dict) -> dict[str, dict]:
    """Topic -> its Topic property (value and QoS), for every display that reads one."""
    topics = {}
    for display in rviz_displays(config):
        topic = display.get("Topic")
        if topic is not None:
            topic = topic if isinstance(topic, dict) else {"Value": topic}
            topics[topic["Value"]] = {**topic, "Class": display["Class"]}
    return topics


def rviz_frames(config: dict) -> set[str]:
    """Every frame an RViz config names (its fixed frame and the displays' own)."""
    frames = {config["Visualization Manager"]["Global Options"]["Fixed Frame"]}
    views = [config["Visualization Manager"]["Views"]["Current"]]
    for item in [*rviz_displays(config), *views]:
        frames |= {item[k] for k in ("Reference Frame", "Target Frame") if k in item}
    return frames - {"<Fixed Frame>"}


def foxglove_panels(layout: dict, kind: str) -> list[dict]:
    """The configs of a Foxglove layout's panels of ``kind`` (3D, RawMessages...)."""
    return [config for key, config in layout["configById"].items() if key.split("!")[0] == kind]


def foxglove_topics(layout: dict) -> set[str]:
    """Every topic a Foxglove layout's panels name (a message path's topic part)."""
    topics = {topic for panel in foxglove_panels(layout, "3D") for topic in panel["topics"]}
    for panel in layout["configById"].values():
        path = panel.get("topicPath")
        if path:
            topics.add(path.split(".")[0].split("{")[0].split("[")[0])
    return topics


def test_the_rviz_config_opens_on_the_swarm_frame_with_its_scene_and_fls_frames():
    config = yaml.safe_load(RVIZ.read_text())
    assert rviz_frames(config) == {SWARM_FRAME}
    classes = [display["Class"] for display in rviz_displays(config)]
    # The FLS frames: RViz's TF display reads /tf and /tf_static itself.
    assert "rviz_default_plugins/TF" in classes
    topics = rviz_topics(config)
    assert set(topics) == {f"/{NAMESPACE}/{names.SCENE_TOPIC}"}
    assert set(topics) <= product_topics()
    # A latched scene reaches only a reader that asks for it (transient local).
    scene = topics[f"/{NAMESPACE}/{names.SCENE_TOPIC}"]
    assert scene["Class"] == "rviz_default_plugins/MarkerArray"
    assert scene["Durability Policy"] == RVIZ_DURABILITY[names.SCENE_QOS.durability]
    assert scene["Reliability Policy"] == RVIZ_RELIABILITY[names.SCENE_QOS.reliability]


def test_the_foxglove_layout_shows_the_scene_in_the_swarm_frame_and_the_raw_measurements():
    layout = json.loads(FOXGLOVE.read_text())
    (panel,) = foxglove_panels(layout, "3D")
    assert panel["followTf"] == SWARM_FRAME
    assert {layer["frameId"] for layer in panel["layers"].values()} == {SWARM_FRAME}
    assert list(panel["topics"]) == [f"/{NAMESPACE}/{names.SCENE_TOPIC}"]
    raw = {config["topicPath"] for config in foxglove_panels(layout, "RawMessages")}
    assert f"/{NAMESPACE}/{names.MEASUREMENTS_TOPIC}" in raw
    assert foxglove_topics(layout) <= product_topics()
    # Every panel of the layout's tree is configured, and every configured one shown.
    shown, pending = set(), [layout["layout"]]
    while pending:
        node = pending.pop()
        if isinstance(node, str):
            shown.add(node)
        else:
            pending += [node["first"], node["second"]]
    assert shown == set(layout["configById"])


@pytest.fixture
def view(context):
    """A real view node in the default namespace, showing an FLS, a path and a move."""
    points = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0]])
    scene = Scene(
        "two FLSs", np.array([0, 1]), points, 0.5, np.ones((2, 4)), [],
        paths=[Polyline(points, "0 -> 1")], moves=[(points[1], points[1] + 1.0)],
    )  # fmt: skip
    node = ViewNode(scene, namespace=NAMESPACE, context=context)
    try:
        yield node
    finally:
        node.destroy_node()


def test_the_viewers_scene_topic_is_the_view_nodes_with_the_type_and_qos_rviz_asks_for(
    view, context
):
    rviz = rviz_topics(yaml.safe_load(RVIZ.read_text()))
    probe = SwarmNode("probe", context=context)
    try:
        for topic, display in rviz.items():
            assert topic in product_topics(), topic  # else no publisher will ever show
            assert wait_until(lambda t=topic: probe.count_publishers(t) > 0, PATIENCE), topic
            types = dict(probe.get_topic_names_and_types())[topic]
            assert types == [RVIZ_TYPES[display["Class"]]]
            (offer,) = probe.get_publishers_info_by_topic(topic)
            assert display["Durability Policy"] == RVIZ_DURABILITY[offer.qos_profile.durability]
            assert display["Reliability Policy"] == RVIZ_RELIABILITY[offer.qos_profile.reliability]
        # The display lists the namespaces of the scene's markers (DELETEALL has none).
        config = yaml.safe_load(RVIZ.read_text())
        (markers,) = [d for d in rviz_displays(config) if d["Class"] in RVIZ_TYPES]
        stamp = probe.get_clock().now().to_msg()
        drawn = {marker.ns for marker in scene_markers(view.scene, stamp).markers}
        assert set(markers["Namespaces"]) == drawn - {""}
        # The layout's 3D panel reads the same topic.
        (panel,) = foxglove_panels(json.loads(FOXGLOVE.read_text()), "3D")
        assert set(panel["topics"]) == set(rviz)
    finally:
        probe.destroy_node()
