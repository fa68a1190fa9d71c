"""The swarm file's format: the examples read, paths from the file's folder, a version, and
a bad file refused in one line naming the file and the key."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from swazure_ros.core.errors import SwazureError
from swazure_ros.files.cloud_files import published_stem
from swazure_ros.files.reading import config_dir
from swazure_ros.files.swarm_file import (
    FILE_VERSION,
    READ_VERSIONS,
    SwarmFile,
    find_swarm_file,
    read_swarm_file,
)

SWARMS = config_dir() / "swarms"
EXAMPLES = sorted(SWARMS.glob("*.yaml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda path: path.stem)
def test_every_example_swarm_file_carries_this_releases_version_and_reads(path):
    assert yaml.safe_load(path.read_text())["fileversion"] == FILE_VERSION
    swarm = read_swarm_file(path)
    assert swarm.version == FILE_VERSION and swarm.path == path
    assert swarm.policy == "shortest-length" and swarm.cloud is not None
    assert (swarm.beta is None) != (swarm.radius is None)


@pytest.mark.parametrize("name", ["dragon", "racecar"])
def test_an_example_names_a_published_cloud_by_its_name(name):
    swarm = read_swarm_file(SWARMS / f"{name}.yaml")
    # The published cloud by its name, read where the published clouds are.
    assert swarm.cloud == name and published_stem(name).startswith(name)
    assert swarm.beta == 0.5


def test_the_torus_example_gives_its_options_and_every_and_one_flss_parameters():
    swarm = read_swarm_file(SWARMS / "torus.yaml")
    assert swarm == SwarmFile(
        SWARMS / "torus.yaml",
        FILE_VERSION,
        cloud="torus:120",
        scale=5.0,
        beta=0.5,
        policy="shortest-length",
        namespace="swarm",
        processes=1,
        parameters={"publish_period": 0.5},
        fls={0: {"publish_period": 0.1, "track.service": True}},
    )


def test_paths_in_a_swarm_file_are_taken_from_its_folder(tmp_path):
    (tmp_path / "clouds").mkdir()
    (tmp_path / "clouds" / "three.xyz").write_text("0 0 0\n1 0 0\n0 1 0\n")
    (tmp_path / "my-sensor.yaml").write_text("kind: published\n")
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  cloud: clouds/three.xyz\n  sensor: my-sensor.yaml\n")
    read = read_swarm_file(swarm)
    assert read.cloud == str(tmp_path / "clouds" / "three.xyz")
    assert read.sensor == tmp_path / "my-sensor.yaml"


def test_a_file_without_a_version_is_read_as_version_1(tmp_path):
    # Every swarm file written before the format had a version is one of version 1.
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("swarm:\n  cloud: torus:60\n  beta: 0.5\n")
    assert read_swarm_file(swarm) == SwarmFile(swarm, 1, cloud="torus:60", beta=0.5)


def test_a_file_of_another_version_is_refused_naming_the_file_and_both_versions(tmp_path):
    swarm = tmp_path / "swarm.yaml"
    # Version 2 may be another format altogether: its version is what is refused.
    swarm.write_text("fileversion: 2\nswarm:\n  robots: {}\nrobot_types: {}\n")
    with pytest.raises(SwazureError) as raised:
        read_swarm_file(swarm)
    assert str(raised.value) == (
        f"{swarm}: fileversion 2, and this release reads swarm files of fileversion 1"
    )
    assert READ_VERSIONS == (1,)


@pytest.mark.parametrize("version", ["'1'", "1.0", "true", "0", "-1", "[1]", "null"])
def test_a_version_that_is_not_a_version_this_release_reads_is_refused(tmp_path, version):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text(f"fileversion: {version}\nswarm:\n  cloud: torus:60\n")
    with pytest.raises(SwazureError, match=r"swarm\.yaml: fileversion .*, and this release"):
        read_swarm_file(swarm)


BAD_FILES = [
    ("swarm: [1, 2\n", "not valid YAML at line 2"),
    ("- just a list\n", "a swarm file is a mapping with the key swarm:"),
    ("cloud: torus\n", "a swarm file is a mapping with the key swarm:"),
    ("fileversion: 1\n", "a swarm file is a mapping with the key swarm:"),
    ("swarm:\n  cloud: torus\nextra: 1\n", "unknown top-level key 'extra'"),
    ("swarm:\n  clowd: torus\n", "unknown key 'clowd' under swarm:"),
    ("swarm:\n  beta: 0.5\n  radius: 1.0\n", "give beta or radius, not both"),
    ("swarm:\n  beta: half\n", "swarm.beta: 'half' is not a number"),
    ("swarm:\n  processes: 0\n", "swarm.processes: 0: must be at least 1"),
    ("swarm:\n  processes: 2.5\n", "swarm.processes: '2.5' is not a whole number"),
    ("swarm:\n  processes: [1, 2]\n", "swarm.processes: expected one value, got a list"),
    ("swarm:\n  domain_id: 300\n", "swarm.domain_id: 300 is outside 0..232"),
    ("swarm:\n  discovery_timeout: -5\n", "swarm.discovery_timeout: -5 s: a duration must"),
    ("swarm:\n  policy: fastest\n", "swarm.policy: 'fastest': expected one of"),
    ("swarm:\n  accurate: maybe\n", "swarm.accurate: 'maybe': expected true or false"),
    ("swarm:\n  seed: -1\n", "swarm.seed: seed -1 is outside 0..2**63-1"),
    ("swarm:\n  sensor: missing.yaml\n", "missing.yaml: no such file"),
    ("swarm:\n  params: .\n", "is a folder, not a file"),
    ("swarm:\n  parameters: 3\n", "swarm.parameters: expected a mapping of ROS parameters"),
    ("swarm:\n  parameters:\n    publish_period: {}\n", "swarm.parameters.publish_period"),
    ("swarm:\n  parameters:\n    mixed: [1, a]\n", "swarm.parameters.mixed: a ROS parameter"),
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
        read_swarm_file(swarm)
    assert message in str(raised.value) and "\n" not in str(raised.value)


def test_an_example_is_found_by_its_name_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert find_swarm_file("trio") == SWARMS / "trio.yaml"
    assert find_swarm_file("trio.yaml") == SWARMS / "trio.yaml"
    # A file of that name here wins over the example.
    (tmp_path / "trio.yaml").write_text("swarm: {}\n")
    assert find_swarm_file("trio.yaml") == Path("trio.yaml")
    with pytest.raises(ValueError, match=r"^nosuch: no such file, nor an example swarm \("):
        find_swarm_file("nosuch")
