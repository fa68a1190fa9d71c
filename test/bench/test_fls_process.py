"""bench.fls_process: the trio's FLSs, each in its own program, timed and measured."""

import sys
from argparse import Namespace
from pathlib import Path

import pytest

from bench.fls_process import fls_process_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_fls_process_section_times_and_measures_each_fls_of_the_trio(domain):
    if not (Path(sys.executable).parents[1] / "lib" / "swazure_ros" / "fls").exists():
        pytest.skip("the swarm's programs are absent (make setup installs them in the venv)")
    lines = fls_process_section(Namespace(beta=0.5), domain=domain)
    [(header, rows)] = check_shape(lines)
    assert header[0] == "FLS" and [row[0] for row in rows] == ["0", "1", "2"]
    for row in rows:
        ready, seen, at_ready, after = (float(cell) for cell in row[1:])
        assert 0 < ready < 60 and 0 < seen < 60 and at_ready > 0 and after > 0
    assert lines[-1].startswith("The pose query took ") and " nan " not in lines[-1]
