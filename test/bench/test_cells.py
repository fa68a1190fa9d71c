"""bench.cells: what each packed process of a small torus hears and spends in one discovery."""

from argparse import Namespace

import pytest

from bench.cells import cells_lines, cells_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_cells_section_measures_a_small_torus_over_two_processes(domain, tmp_path):
    lines = cells_section(
        Namespace(beta=0.5), runs=(("torus:120", 2),), domain=domain, figures=tmp_path,
        records_dir=tmp_path,
    )  # fmt: skip
    [(header, [row])] = check_shape(lines)
    assert header[:3] == ["shape", "FLSs", "processes"] and header[-1] == "identical"
    assert row[0] == "torus:120" and row[2] == "2" and "stopped" not in row[3], row
    assert int(row[1].replace(",", "")) > 100 and int(row[8]) > 0  # FLSs, rounds
    cells_heard = [int(one) for one in row[11].split(" / ")]
    assert len(cells_heard) == 2 and all(one > 0 for one in cells_heard)
    assert row[-1] == "yes"
    assert (tmp_path / "cells-per-fls.png").read_bytes().startswith(b"\x89PNG")


def test_a_stopped_cells_run_says_why_in_its_row():
    stopped = {"shape": "torus:30000", "processes": 2, "stopped": "exit 1: no memory"}
    [(_, [row])] = check_shape(cells_lines([stopped]))
    assert row[:4] == ["torus:30000", "-", "2", "stopped: exit 1: no memory"]
