"""bench.hosts: one process per FLS across hosts, its tables and figures."""

from bench.hosts import hosts_figures, hosts_lines


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
