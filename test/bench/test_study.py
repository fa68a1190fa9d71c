"""bench.study: a narrow study, cold and then cached, timed and measured."""

from argparse import Namespace

import pytest

from bench.study import study_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_study_section_times_a_study_cold_and_then_with_nothing_changed():
    narrow = ["--clouds", "torus:200", "--betas", "0.5", "--policies", "shortest-length",
              "--heuristic-betas", "0.5", "--techniques", "move-source:2"]  # fmt: skip
    lines = study_section(Namespace(beta=0.5), options=narrow, shape="torus_200", runs=2)
    [(header, rows)] = check_shape(lines)
    assert header == ["case", "runs computed", "wall s", "peak MB", "output MB"]
    assert [row[:2] for row in rows] == [["cold", "2"], ["cached", "0"]]
    assert all(float(row[2]) > 0 and int(row[3]) > 0 for row in rows)
