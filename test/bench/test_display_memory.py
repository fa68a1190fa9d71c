"""bench.display_memory: peak memory against size at one --memory, judged flat or not, plotted."""

import argparse

import pytest

from bench.display import DisplayRow
from bench.display_memory import display_memory_section, flat_verdict

from .tables import check_shape


def _row(shape, size, peak_mb, exit_code=0):
    return DisplayRow(shape, size, "plain", size, 10 * size, 1.0, peak_mb, exit_code, "", "-")


def test_a_peak_within_the_ratio_of_the_smallest_sizes_is_flat_and_one_beyond_it_is_not():
    flat = [_row("torus", 65536, 1150.0), _row("torus", 10000, 1000.0)]
    assert "1.15x, flat" in flat_verdict(flat, "torus")
    grown = [_row("racecar", 10000, 1000.0), _row("racecar", 65536, 1250.0)]
    assert "1.25x, not flat" in flat_verdict(grown, "racecar")
    failed = [_row("torus", 10000, 1000.0), _row("torus", 65536, 900.0, exit_code=-9)]
    assert "not judged" in flat_verdict(failed, "torus")


@pytest.mark.bench_section
def test_the_memory_section_runs_each_size_at_the_fixed_memory_and_plots_the_peaks(tmp_path):
    figure = tmp_path / "display-memory.png"
    lines = display_memory_section(
        argparse.Namespace(beta=0.5), ("torus",), (150, 200), figure, tmp_path
    )
    [(_header, table)] = check_shape(lines)
    # A torus of about the size asked for: the table gives the FLSs it has.
    assert [row[:2] for row in table] == [["torus", "147"], ["torus", "200"]]
    assert all("exit" not in row[2] and float(row[3].replace(",", "")) > 0 for row in table)
    assert sum(line.startswith("- torus: ") for line in lines) == 1
    assert figure.read_bytes().startswith(b"\x89PNG")
