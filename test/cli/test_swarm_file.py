"""A swarm file on the command line: flags override the file, a bad file gets one line and
exit 2 (the format's own checks: test/files/test_swarm_file.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from swazure_ros.app.config import load_swarm_file
from swazure_ros.cli.main import build_parser
from swazure_ros.cli.options import swarm_setup_from_args
from swazure_ros.cli.swarm_file import apply_swarm_file
from swazure_ros.core.evaluate import evaluate
from swazure_ros.files.cloud_files import is_cloud_path, published_dataset_dir, published_stem
from swazure_ros.files.reading import config_dir

from ..waits import PATIENCE

SWARMS = config_dir() / "swarms"
TORUS = SWARMS / "torus.yaml"


def spawn_args(*argv: str):
    """``swazure spawn ARGV`` parsed, with the swarm file applied."""
    return apply_swarm_file(build_parser().parse_args(["spawn", *argv]))


def test_a_swarm_file_sets_the_options_and_every_and_one_flss_parameters():
    args = spawn_args(str(TORUS))
    assert (args.cloud, args.beta, args.radius, args.processes) == ("torus:120", 0.5, None, 1)
    assert args.scale == 5
    assert args.namespace == "swarm" and args.policy == "shortest-length"
    assert args.discovery_timeout == 600.0 and args.seed == 0 and args.accurate is False
    assert args.parameters == {"publish_period": 0.5}
    assert args.fls_parameters == {0: {"publish_period": 0.1, "track.service": True}}


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


NOT_AN_FLS_PARAMETER = (
    "swarm.parameters.round_timeout: no FLS node has this parameter (theirs: publish_period, "
)


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


@pytest.mark.parametrize("verb", ["spawn", "evaluate"])
def test_a_swarm_file_of_another_version_is_refused_in_one_line_with_exit_2(tmp_path, verb):
    swarm = tmp_path / "swarm.yaml"
    swarm.write_text("fileversion: 2\nswarm:\n  cloud: torus:60\n  beta: 0.5\n")
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", verb, str(swarm)],
        capture_output=True,
        text=True,
        timeout=PATIENCE,
        cwd=tmp_path,
    )
    assert run.returncode == 2, run.stderr
    assert run.stderr == (
        f"swazure {verb}: error: {swarm}: fileversion 2, and this release reads swarm files "
        "of fileversion 1\n"
    )
    assert run.stdout == ""
    assert sorted(p.name for p in tmp_path.iterdir()) == ["swarm.yaml"]


def evaluate_args(*argv: str):
    """``swazure evaluate ARGV`` parsed, with the swarm file applied."""
    return apply_swarm_file(build_parser().parse_args(["evaluate", *argv]))


@pytest.mark.parametrize("path", sorted(SWARMS.glob("*.yaml")), ids=lambda path: path.stem)
def test_every_example_swarm_has_blind_pairs_with_sweet_paths(path):
    # A user's first swarm must be one whose FLSs see each other.
    options = load_swarm_file(path)
    assert options.cloud is not None and options.policy is not None
    if is_cloud_path(options.cloud) and not Path(options.cloud).exists():
        pytest.skip(f"{options.cloud} is absent (../shared is not beside the repo)")
    stem = published_stem(options.cloud)
    folder = published_dataset_dir()
    if stem is not None and (folder is None or not (folder / f"{stem}.xyz").is_file()):
        pytest.skip(f"the published cloud {stem}.xyz is absent (../shared is not beside the repo)")
    setup = swarm_setup_from_args(evaluate_args(str(path)))
    swarm, sensor = setup.swarm, setup.sensor
    pairs = evaluate(swarm, sensor, options.policy).summary.pairs
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
