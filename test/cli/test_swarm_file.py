"""A swarm in one file: the examples load, flags override the file, bad files get one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from swazure_ros.cli.main import build_parser
from swazure_ros.cli.options import swarm_setup_from_args
from swazure_ros.cli.swarm_file import apply_swarm_file, load_swarm_file
from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.files.cloud_files import is_cloud_path, published_dataset_dir, published_stem
from swazure_ros.files.reading import config_dir

from ..waits import PATIENCE

SWARMS = config_dir() / "swarms"
TORUS = SWARMS / "torus.yaml"


def spawn_args(*argv: str):
    """``swazure spawn ARGV`` parsed, with the swarm file applied."""
    return apply_swarm_file(build_parser().parse_args(["spawn", *argv]))


@pytest.mark.parametrize("name", ["torus", "dragon", "racecar"])
def test_every_example_swarm_file_loads(name):
    options = load_swarm_file(SWARMS / f"{name}.yaml")
    assert options["beta"] == 0.5 and options["policy"] == "shortest-length"
    if name != "torus":
        # The published cloud by its name, read where the published clouds are.
        assert options["cloud"] == name and published_stem(name).startswith(name)


def test_a_swarm_file_sets_the_options_and_every_and_one_flss_parameters():
    args = spawn_args(str(TORUS))
    assert (args.cloud, args.beta, args.radius, args.processes) == ("torus:120", 0.5, None, 1)
    assert args.scale == 5
    assert args.namespace == "swarm" and args.policy == "shortest-length"
    assert args.discovery_timeout == 600.0 and args.seed == 0 and args.accurate is False
    assert args.parameters == {"publish_period": 0.5}
    assert args.fls_parameters == {0: {"publish_period": 0.1, "track.service": True}}


def test_a_whole_number_for_a_double_parameter_is_taken_as_that_double(tmp_path):
    # rclpy refuses an integer for a double parameter; the file's 1 means 1.0.
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  parameters:\n    publish_period: 2\n    camera_view: 3\n")
    parameters = load_swarm_file(swarm)["parameters"]
    assert parameters == {"publish_period": 2.0, "camera_view": 3}
    assert type(parameters["publish_period"]) is float and type(parameters["camera_view"]) is int


def test_flags_given_beside_the_file_override_it():
    args = spawn_args(str(TORUS), "--processes", "2", "--radius", "1.5", "--namespace", "show")
    assert args.processes == 2 and args.namespace == "show"
    # The command line's radius replaces the file's beta.
    assert args.radius == 1.5 and args.beta is None
    assert args.cloud == "torus:120"  # not given: the file's


def test_without_a_file_the_flags_keep_their_defaults():
    args = spawn_args("--beta", "0.5")
    assert (args.cloud, args.processes, args.namespace) == ("torus", 1, "swarm")
    assert args.policy == "shortest-length" and args.discovery_timeout == 600.0
    assert args.parameters == {} and args.fls_parameters == {}


def test_paths_in_a_swarm_file_are_taken_from_its_folder(tmp_path):
    (tmp_path / "clouds").mkdir()
    (tmp_path / "clouds" / "three.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    (tmp_path / "my-sensor.yaml").write_text("kind: published\n")
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  cloud: clouds/three.xyz\n  sensor: my-sensor.yaml\n")
    options = load_swarm_file(swarm)
    assert options["cloud"] == str(tmp_path / "clouds" / "three.xyz")
    assert options["sensor"] == tmp_path / "my-sensor.yaml"


NOT_AN_FLS_PARAMETER = (
    "swarm.parameters.round_timeout: no FLS node has this parameter (theirs: publish_period, "
)
BAD_FILES = [
    ("swarm: [1, 2\n", "not valid YAML at line 2"),
    ("- just a list\n", "a mapping with one key, swarm:"),
    ("cloud: torus\n", "a mapping with one key, swarm:"),
    ("swarm:\n  cloud: torus\nextra: 1\n", "unknown top-level key 'extra'"),
    ("swarm:\n  clowd: torus\n", "unknown key 'clowd' under swarm:"),
    ("swarm:\n  beta: 0.5\n  radius: 1.0\n", "give beta or radius, not both"),
    ("swarm:\n  beta: half\n", "swarm.beta: 'half' is not a number"),
    ("swarm:\n  processes: 0\n", "swarm.processes: 0: must be at least 1"),
    ("swarm:\n  processes: 2.5\n", "swarm.processes: '2.5' is not a whole number"),
    ("swarm:\n  processes: [1, 2]\n", "swarm.processes: expected one value, got a list"),
    ("swarm:\n  namespace: bad name!\n", "swarm.namespace: 'bad name!' is not a ROS namespace"),
    ("swarm:\n  domain_id: 300\n", "swarm.domain_id: 300 is outside 0..232"),
    ("swarm:\n  discovery_timeout: -5\n", "swarm.discovery_timeout: -5 s: a duration must"),
    ("swarm:\n  policy: fastest\n", "swarm.policy: 'fastest': expected one of"),
    ("swarm:\n  accurate: maybe\n", "swarm.accurate: 'maybe': expected true or false"),
    ("swarm:\n  sensor: missing.yaml\n", "missing.yaml: no such file"),
    ("swarm:\n  params: .\n", "is a folder, not a file"),
    ("swarm:\n  parameters: 3\n", "swarm.parameters: expected a mapping of ROS parameters"),
    ("swarm:\n  parameters:\n    publish_period: {}\n", "swarm.parameters.publish_period"),
    ("swarm:\n  parameters:\n    mixed: [1, a]\n", "swarm.parameters.mixed: a ROS parameter"),
    # Issue 66: a name no FLS node has was ignored by every node without a word.
    ("swarm:\n  parameters:\n    round_timeout: 0.0\n", NOT_AN_FLS_PARAMETER),
    ("swarm:\n  fls:\n    2: {round_timeout: 5.0}\n", "swarm.fls.2.round_timeout: no FLS node"),
    ("swarm:\n  parameters:\n    publish_period: 0.0\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: -1\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: .nan\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: .inf\n", "publish_period must be a positive"),
    ("swarm:\n  parameters:\n    publish_period: fast\n", "expected a double, got 'fast'"),
    ("swarm:\n  parameters:\n    track: {timeout: 0.0}\n", "track: timeout must be above 0"),
    ("swarm:\n  fls:\n    0: {join_timeout: -3.0}\n", "fls.0.join_timeout must be a positive"),
    ("swarm:\n  fls: [1]\n", "swarm.fls: expected FLS ids, each with its parameters"),
    ("swarm:\n  fls:\n    first: {publish_period: 1.0}\n", "swarm.fls: 'first' is not a whole"),
    ("swarm:\n  fls:\n    -3: {publish_period: 1.0}\n", "swarm.fls: FLS id -3 is outside"),
    ("swarm:\n  fls:\n    3: 1.0\n", "swarm.fls.3: expected a mapping of ROS parameters"),
]


@pytest.mark.parametrize(("content", "message"), BAD_FILES)
def test_a_bad_swarm_file_is_refused_with_the_file_and_key_named(tmp_path, content, message):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text(content)
    with pytest.raises(SwazureError, match=r"swarm\.yaml: ") as raised:
        load_swarm_file(swarm)
    assert message in str(raised.value) and "\n" not in str(raised.value)


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("swarm:\n  clowd: torus\n", "unknown key 'clowd' under swarm:"),
        ("swarm:\n  cloud: torus:60\n", "give --beta"),
        ("swarm:\n  cloud: nosuch.xyz\n  beta: 0.5\n", "nosuch.xyz"),
        (
            "swarm:\n  cloud: torus:60\n  beta: 0.5\n  fls:\n    999: {publish_period: 1.0}\n",
            "parameters for FLS 999: no such FLS in this swarm of 60",
        ),
        # Issue 66, as reported: the swarm came up and no node took the timeout.
        (
            "swarm:\n  cloud: torus:60\n  beta: 0.5\n  parameters:\n    round_timeout: 0.0\n",
            NOT_AN_FLS_PARAMETER,
        ),
    ],
)
def test_spawn_with_a_bad_swarm_file_says_so_in_one_line_and_writes_nothing(
    tmp_path, content, message
):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text(content)
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", str(swarm), "--until-ready"],
        capture_output=True,
        text=True,
        timeout=PATIENCE,
        cwd=tmp_path,
    )
    assert run.returncode == 2, run.stderr
    assert message in run.stderr and len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "Traceback" not in run.stdout + run.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["swarm.yaml"]


def evaluate_args(*argv: str):
    """``swazure evaluate ARGV`` parsed, with the swarm file applied."""
    return apply_swarm_file(build_parser().parse_args(["evaluate", *argv]))


@pytest.mark.parametrize("path", sorted(SWARMS.glob("*.yaml")), ids=lambda path: path.stem)
def test_every_example_swarm_has_blind_pairs_with_sweet_paths(path):
    # A user's first swarm must be one whose FLSs see each other.
    options = load_swarm_file(path)
    if is_cloud_path(options["cloud"]) and not Path(options["cloud"]).exists():
        pytest.skip(f"{options['cloud']} is absent (../shared is not beside the repo)")
    stem = published_stem(options["cloud"])
    folder = published_dataset_dir()
    if stem is not None and (folder is None or not (folder / f"{stem}.xyz").is_file()):
        pytest.skip(f"the published cloud {stem}.xyz is absent (../shared is not beside the repo)")
    setup = swarm_setup_from_args(evaluate_args(str(path)))
    swarm, sensor = setup.swarm, setup.sensor
    pairs = evaluate(swarm, sensor, options["policy"]).summary.pairs
    assert pairs.blind_pairs > 0 and pairs.sweet_pairs > 0, (path.name, pairs)


def test_evaluate_takes_a_swarm_file_and_a_flag_beside_it_wins():
    args = evaluate_args(str(TORUS))
    assert (args.cloud, args.scale, args.beta, args.policy) == (
        "torus:120",
        5,
        0.5,
        "shortest-length",
    )
    args = evaluate_args(str(TORUS), "--scale", "1", "--policy", "fewest-hops")
    assert (args.scale, args.policy) == (1, "fewest-hops")
