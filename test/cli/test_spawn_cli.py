"""``swazure spawn`` in a real process over real DDS: a swarm whose spacing does not fit its
sensor says why and names ``--scale``, served or computed."""

import signal
import subprocess
import sys
import threading

import pytest

from swazure_ros.cli.main import build_parser
from swazure_ros.cli.spawn import config_from_args
from swazure_ros.cli.swarm_file import apply_swarm_file

from ..waits import PATIENCE, wait_until

WARNING = "swazure spawn: warning: no pair of FLSs is a hop the sensor measures"
SCALE = "the cloud's spacing does not fit the sensor: --scale 3.4 would"


def test_a_served_torus_without_its_scale_warns_as_it_comes_up(domain):
    # Issue 69, as written: the example file's torus uses --scale 5.
    with subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", "--cloud", "torus:120",
         "--beta", "0.5"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    ) as process:  # fmt: skip
        errors: list[str] = []
        output: list[str] = []
        readers = [
            threading.Thread(target=lambda: errors.extend(process.stderr), daemon=True),
            threading.Thread(target=lambda: output.extend(process.stdout), daemon=True),
        ]
        for reader in readers:
            reader.start()

        def said(lines: list[str], text: str) -> bool:
            return any(text in line for line in lines)

        try:
            assert wait_until(lambda: said(errors, WARNING), PATIENCE)
            # Up (SIGTERM while it comes up is an interruption, 130): the warning stopped nothing.
            assert wait_until(lambda: said(output, "swarm up"), PATIENCE)
        finally:
            process.send_signal(signal.SIGTERM)
            process.wait(PATIENCE)
            for reader in readers:
                reader.join(PATIENCE)
    warning = next(line for line in errors if WARNING in line)
    assert warning.rstrip().endswith(SCALE)
    # A served swarm ends on SIGTERM as on Ctrl-C: exit 0, the warning was no error.
    assert process.returncode == 0, "".join(errors)


def test_a_computed_torus_without_its_scale_says_why_under_its_summary(domain):
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "spawn", "--cloud", "torus:120",
         "--beta", "0.5", "--compute-all", "--quiet"],
        capture_output=True, text=True, timeout=2 * PATIENCE,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    why = next(line for line in lines if line.startswith("why: "))
    assert lines.index(why) == next(i for i, line in enumerate(lines) if "identical" in line) - 1
    assert why.startswith("why: no pair of FLSs is a hop the sensor measures")
    assert why.endswith(SCALE)
    # Warned once, as the swarm came up.
    assert [line for line in run.stderr.splitlines() if "warning" in line] == [
        f"swazure spawn: warning: {why.removeprefix('why: ')}"
    ]


@pytest.mark.parametrize(
    ("flags", "whole"),
    [
        (["--compute-all"], False),  # compared with the engine block by block
        ([], False),
        (["--view"], True),  # the view draws every pair
        (["--compute-all", "--technique", "move-source"], True),  # the swarm's moves
        (["--compute-all", "--estimator", "swarm-fit"], True),  # the swarm's fit
    ],
)
def test_the_launcher_holds_every_pair_only_for_the_view_and_the_swarms_moves_and_fits(
    flags, whole
):
    argv = ["spawn", "--cloud", "torus:120", "--scale", "1.6", "--beta", "0.5", *flags]
    args = apply_swarm_file(build_parser().parse_args(argv))
    assert config_from_args(args).whole_world is whole
