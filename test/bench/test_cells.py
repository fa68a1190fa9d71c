"""bench.cells: what each packed process of a small torus hears and spends in one discovery."""

import json
import math
from argparse import Namespace

import pytest

from bench.cells import cells_lines, cells_section, per_fls_round
from bench.cells import main as cells_main

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


def record(flss, processes, bytes_heard=None):
    """A measure_cells record made by hand: each process hosts an equal share and spent
    1 s of CPU, 100 MB at its peak and (if given) ``bytes_heard`` bytes over 10 rounds."""
    per = [
        {"flss": flss // processes, "cells": 1, "offers_over_dds": 10, "cpu_s": 1.0,
         "peak_mb": 100.0, **({} if bytes_heard is None else {"bytes_over_dds": bytes_heard})}
        for _ in range(processes)
    ]  # fmt: skip
    return {
        "cloud": f"torus:{flss}", "flss": flss, "processes": processes, "bring_up_s": 1.0,
        "peak_mb": 100.0 * processes, "discovery_s": 2.0, "rounds": 10, "source_runs": 1,
        "engine_s": 1.0, "identical": "yes", "radio_messages": 1, "radio_bytes": 1,
        "radio_topics": 1, "per_process": per,
    }  # fmt: skip


def test_per_fls_round_is_the_busiest_process_s_spend_over_its_flss_and_the_rounds():
    spent = per_fls_round(record(2000, 2, bytes_heard=5_000_000))
    # 1,000 FLSs a process, 10 rounds: 5 MB heard is 0.5 KB an FLS-round, 1 s is 0.1 ms.
    assert spent == pytest.approx({"heard_kb": 0.5, "cpu_ms": 0.1, "peak_kb": 100.0})
    assert math.isnan(per_fls_round(record(2000, 2))["heard_kb"])  # counted from e15b506 on


def test_records_by_file_make_the_section_s_table_and_figure(tmp_path, capsys):
    files = []
    for index, one in enumerate([record(10000, 2, 8_000_000), record(30000, 4)]):
        files.append(tmp_path / f"{index}.json")
        files[-1].write_text(json.dumps(one))
    assert cells_main([*map(str, files), "--figure", str(tmp_path / "cells.png")]) == 0
    [(header, rows)] = check_shape(capsys.readouterr().out.splitlines())
    heard = header.index("DDS KB heard per FLS-round")
    assert [row[0] for row in rows] == ["torus:10000", "torus:30000"]
    assert [row[heard] for row in rows] == ["0.16", "-"]  # 8 MB / 5,000 FLSs / 10 rounds
    assert (tmp_path / "cells.png").read_bytes().startswith(b"\x89PNG")


def test_a_record_that_cannot_be_read_is_one_line_and_exit_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        cells_main([str(tmp_path / "missing.json"), "--figure", str(tmp_path / "x.png")])
    assert exit_.value.code == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert "error: cannot read a record" in said[-1]
    assert not (tmp_path / "x.png").exists()
