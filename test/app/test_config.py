"""A swarm's config refuses a layout of processes that cannot run, in the command line's words;
a swarm file is checked by what runs it, and describes a config alone."""

import pytest

from swazure_ros.app.config import (
    FLS_SERVICES_UP_TO,
    SwarmConfig,
    config_from_file,
    load_swarm_file,
)
from swazure_ros.core.errors import SwazureError
from swazure_ros.files.reading import config_dir
from swazure_ros.sim.world import WorldSpec

WORLD = WorldSpec("torus", beta=0.5)


@pytest.mark.parametrize(
    ("layout", "message"),
    [
        ({"processes": 0}, "--processes must be at least 1"),
        ({"processes": 2, "hosts": 2}, "--share runs one process per host"),
        ({"share": 3, "hosts": 2}, "--share 3/2: no such share"),
        ({"processes": 2, "per_fls": True}, "--per-fls runs one process per FLS"),
        ({"neighbour_services": "some"}, "--neighbour-services must be one of auto, fls, hosts"),
        ({"neighbour_services": "hosts", "per_fls": True}, "alone in its process"),
    ],
)
def test_a_layout_that_cannot_run_is_refused(layout, message):
    with pytest.raises(SwazureError, match=message):
        SwarmConfig(WORLD, **layout)


def test_a_layout_that_can_run_is_kept():
    config = SwarmConfig(WORLD, processes=2)
    assert (config.processes, config.share, config.hosts) == (2, 0, 1)


def test_each_fls_answers_for_itself_up_to_the_published_shapes_size_and_hosts_above():
    assert FLS_SERVICES_UP_TO >= 3_720  # the race car, the largest published shape
    auto = SwarmConfig(WORLD)
    assert auto.fls_services(FLS_SERVICES_UP_TO) and not auto.fls_services(FLS_SERVICES_UP_TO + 1)
    # One FLS to a process: it answers for itself, whatever the swarm's size.
    assert SwarmConfig(WORLD, per_fls=True).fls_services(100_000)
    assert SwarmConfig(WORLD, neighbour_services="fls").fls_services(100_000)
    assert not SwarmConfig(WORLD, neighbour_services="hosts").fls_services(10)


NOT_AN_FLS_PARAMETER = (
    "swarm.parameters.round_timeout: no FLS node has this parameter (theirs: publish_period, "
)
#: What ROS and the FLS node refuse of a swarm file that its format takes.
REFUSED_BY_WHAT_RUNS_IT = [
    ("swarm:\n  namespace: bad name!\n", "swarm.namespace: 'bad name!' is not a ROS namespace"),
    ("swarm:\n  namespace: /\n", "swarm.namespace: a namespace needs a name"),
    # Issue 66: a name no FLS node has was ignored by every node without a word.
    ("swarm:\n  parameters:\n    round_timeout: 0.0\n", NOT_AN_FLS_PARAMETER),
    ("swarm:\n  fls:\n    2: {round_timeout: 5.0}\n", "swarm.fls.2.round_timeout: no FLS node"),
    ("swarm:\n  parameters:\n    publish_period: 0.0\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: -1\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: .nan\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: .inf\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: fast\n", "expected a double, got 'fast'"),
    ("swarm:\n  parameters:\n    publish_period: [1.0]\n", "expected a double, got [1.0]"),
    ("swarm:\n  parameters:\n    track: {timeout: 0.0}\n", "track: timeout must be above 0"),
    ("swarm:\n  fls:\n    0: {join_timeout: -3.0}\n", "fls.0.join_timeout must be a positive"),
    # The format's own refusals come first, through the same loader.
    ("fileversion: 3\nswarm: {}\n", "fileversion 3, and this release reads"),
]


@pytest.mark.parametrize(("content", "message"), REFUSED_BY_WHAT_RUNS_IT)
def test_a_swarm_file_is_refused_what_ros_and_the_fls_node_refuse(tmp_path, content, message):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text(content)
    with pytest.raises(SwazureError, match=r"swarm\.yaml: ") as raised:
        load_swarm_file(swarm)
    assert message in str(raised.value) and "\n" not in str(raised.value)


def test_a_whole_number_for_a_double_parameter_is_taken_as_that_double(tmp_path):
    # rclpy refuses an integer for a double parameter; the file's 1 means 1.0.
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  parameters:\n    publish_period: 2\n    camera_view: 3\n")
    parameters = load_swarm_file(swarm).parameters
    assert parameters == {"publish_period": 2.0, "camera_view": 3}
    assert type(parameters["publish_period"]) is float and type(parameters["camera_view"]) is int


def test_a_namespace_is_kept_without_its_leading_slash(tmp_path):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  namespace: /show/left\n")
    assert load_swarm_file(swarm).namespace == "show/left"


def test_the_config_of_a_file_alone_takes_spawns_defaults_for_what_it_leaves_out(tmp_path):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("fileversion: 1\nswarm:\n  radius: 1.5\n")
    config = config_from_file(load_swarm_file(swarm))
    assert config == SwarmConfig(
        WorldSpec("torus", radius=1.5),
        params_file=str(config_dir() / "swarm.yaml"),
    )


def test_the_config_of_the_torus_example_is_what_it_says():
    path = config_dir() / "swarms" / "torus.yaml"
    config = config_from_file(load_swarm_file(path))
    assert config.world == WorldSpec("torus:120", scale=5.0, beta=0.5)
    assert (config.processes, config.namespace, config.domain_id) == (1, "swarm", None)
    assert config.parameters == {"publish_period": 0.5}
    assert config.fls_parameters == {0: {"publish_period": 0.1, "track.service": True}}


def test_the_config_of_a_file_without_beta_or_radius_is_refused_naming_the_file(tmp_path):
    # A command line may give the size beside the file; the file alone must.
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  cloud: torus:60\n")
    with pytest.raises(SwazureError, match=r"swarm\.yaml: give swarm\.beta .* or swarm\.radius"):
        config_from_file(load_swarm_file(swarm))
