"""bench.hosts: one process per FLS across hosts, its tables and figures."""

import json
import os
from argparse import Namespace

import pytest

from bench.hosts import hosts_figures, hosts_lines, hosts_row, hosts_section

from ..netns import hosts_unavailable
from .tables import cells, check_shape


def test_the_hosts_section_gives_cpu_per_fls_process_and_draws_three_figures(tmp_path):
    up = {"flss": 25, "discovery": "server", "fls_processes": 24, "bring_up_s": 9.0,
          "bring_up_cpu_s": 18.0, "bring_up_packets": 10, "bring_up_bytes": 2e6}  # fmt: skip
    stopped = {"flss": 200, "discovery": "server", "fls_processes": 200, "cpu_s": 900.0,
               "stopped": "bring-up: swarm not discovered after 420 s: 68 of 200",
               "stopped_packets": 5, "stopped_bytes": 1e9}  # fmt: skip
    lines = hosts_lines([up, stopped])
    row = next(line for line in lines if line.startswith("| 24 | server"))
    assert row.split("|")[5].strip() == "0.75"  # 18 CPU s over 24 FLS processes
    hosts_figures([up, stopped], tmp_path)
    names = ("hosts-bringup.png", "hosts-traffic.png", "hosts-cpu.png")
    assert all((tmp_path / name).read_bytes().startswith(b"\x89PNG") for name in names)


@pytest.mark.bench_section
def test_the_hosts_section_counts_the_fls_processes_of_a_tiny_torus_over_two_hosts(tmp_path):
    reason = hosts_unavailable()
    if reason is not None:
        pytest.skip(reason)
    lines = hosts_section(
        Namespace(beta=0.5), sizes=(8,), hosts=2, discoveries=("server",), figures=tmp_path,
        records_dir=tmp_path, prefix=f"swzb{os.getpid() % 10000}",
    )  # fmt: skip
    record = json.loads((tmp_path / "hosts-8-server.json").read_text())
    assert "stopped" not in record, record
    assert record["fls_processes"] > 0 and record["bring_up_cpu_s"] > 0
    assert record["bring_up_packets"] > 0 and record["fls_rss_mb_mean"] > 0
    [(header, rows)] = check_shape(lines)[:1]
    assert header[:2] == ["FLS processes", "discovery"]
    assert rows == [cells(hosts_row(record))] and int(rows[0][0]) == record["fls_processes"]
    assert (tmp_path / "hosts-cpu.png").read_bytes().startswith(b"\x89PNG")
