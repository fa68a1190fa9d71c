"""bench.speed: the installed command's wall, timed on a small torus and one verb's help."""

import sys
from argparse import Namespace
from pathlib import Path

import pytest

from bench.speed import speed_section

from .tables import check_shape


def test_the_speed_section_times_evaluate_the_version_and_a_help_against_their_targets():
    if not (Path(sys.executable).parent / "swazure").exists():
        pytest.skip("the installed swazure command is absent (make setup installs it)")
    lines = speed_section(
        Namespace(beta=0.5), shapes=(("torus:60", 1, "10 s"),), verbs=("key",), times=1
    )
    [(header, rows)] = check_shape(lines)
    assert header == ["command", "runs", "median s", "range s", "target", "met"]
    assert [row[0] for row in rows] == [
        "`swazure evaluate` torus:60, beta 0.5, shortest-length", "`swazure --version`",
        "`swazure key --help`",
    ]  # fmt: skip
    assert all(row[1] == "1" and float(row[2]) > 0 and row[5] in ("yes", "no") for row in rows)
