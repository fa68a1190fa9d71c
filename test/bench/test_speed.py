"""bench.speed: the command's wall with outputs on a small torus, its phases, one help."""

import sys
from argparse import Namespace
from pathlib import Path

import pytest

from bench.speed import speed_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_speed_section_times_evaluate_the_version_and_a_help_against_their_targets():
    if not (Path(sys.executable).parent / "swazure").exists():
        pytest.skip("the installed swazure command is absent (make setup installs it)")
    lines = speed_section(
        Namespace(beta=0.5), shapes=(("torus:60", 1, "10 s"),), verbs=("key",), times=1
    )
    [(header, rows), (phase_header, phases)] = check_shape(lines)
    assert header == ["command", "runs", "median s", "range s", "target", "met"]
    assert [row[0] for row in rows] == [
        "`swazure evaluate --out` torus:60, beta 0.5, shortest-length", "`swazure --version`",
        "`swazure key --help`",
    ]  # fmt: skip
    assert all(row[1] == "1" and float(row[2]) > 0 and row[5] in ("yes", "no") for row in rows)
    # One run's phases, to the millisecond: the imports and the kernels' first dispatch
    # take tenths; the tables and torus:60's pairs.csv take a few milliseconds, which
    # a busy machine's clock may round to none, so they are only never negative.
    assert phase_header[:2] == ["shape", "wall s"]
    [phase] = phases
    assert phase[0] == "torus:60"
    wall, start, imports, kernels, engine, tables, csv = map(float, phase[1:])
    assert min(imports, kernels) > 0 and min(tables, csv) >= 0
    assert all(len(cell.split(".")[1]) == 3 for cell in phase[1:])
    assert start + imports + kernels + engine + tables + csv == pytest.approx(wall, abs=0.01)
