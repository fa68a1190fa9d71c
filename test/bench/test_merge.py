"""scripts/bench.py: how a run of some sections is merged into BENCHMARKS.md."""

import importlib.util
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "bench" / "__main__.py"


def bench():
    spec = importlib.util.spec_from_file_location("bench", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_section_with_two_headings_replaces_both_and_stays_once_when_run_again():
    existing = (
        "# Benchmarks\n\n## Core engine\n\nold engine\n\n## Heuristics\n\nold\n\n"
        "## Swarm\n\nkept\n"
    )
    fresh = [["## Core engine", "", "stamp", "", "new engine", "", "## Heuristics", "", "new", ""]]
    once = bench().merged(existing, fresh)
    assert once.count("## Heuristics") == 1 and "old" not in once
    assert once.index("## Core engine") < once.index("## Heuristics") < once.index("## Swarm")
    assert "kept" in once
    assert bench().merged(once, fresh) == once


def test_the_tags_section_times_each_offer_keyed_and_plain_and_the_auth_is_48_bytes():
    module = bench()
    module.TAG_LABELS, module.TAG_REPEATS = (0, 10), 3
    lines = module.tags_section(None)
    rows = [line.split("|")[1:-1] for line in lines if line.startswith("| 0 ") or
            line.startswith("| 10 ")]  # fmt: skip
    assert [int(row[0]) for row in rows] == [0, 10]
    for row in rows:
        keyed, plain = int(row[1]), int(row[2])
        assert keyed == plain + 48  # sender, counter, HMAC-SHA256
        assert all(float(cell) > 0 for cell in row[3:7])


def test_the_hosts_section_gives_cpu_per_fls_process_and_draws_three_figures(tmp_path):
    module = bench()
    up = {"flss": 25, "discovery": "server", "fls_processes": 24, "bring_up_s": 9.0,
          "bring_up_cpu_s": 18.0, "bring_up_packets": 10, "bring_up_bytes": 2e6}  # fmt: skip
    stopped = {"flss": 200, "discovery": "server", "fls_processes": 200, "cpu_s": 900.0,
               "stopped": "bring-up: swarm not discovered after 420 s: 68 of 200",
               "stopped_packets": 5, "stopped_bytes": 1e9}  # fmt: skip
    lines = module.hosts_lines([up, stopped])
    row = next(line for line in lines if line.startswith("| 24 | server"))
    assert row.split("|")[5].strip() == "0.75"  # 18 CPU s over 24 FLS processes
    module.hosts_figures([up, stopped], tmp_path)
    names = ("hosts-bringup.png", "hosts-traffic.png", "hosts-cpu.png")
    assert all((tmp_path / name).read_bytes().startswith(b"\x89PNG") for name in names)


def test_a_soaks_counts_give_memory_and_every_counter_or_only_the_drops():
    module = bench()
    samples = [(0.0, 300.0), (5.0, 320.0), (10.0, 310.0)]
    values = {"accepted world": "3", "dropped world: forged": "7"}
    counts = {"swazure: /swarm/host_0 inbound messages": values}
    every = module.soak_counts(samples, "soak.png", counts)
    assert "300 MB at the start, 310 MB at the end (max 320 MB)" in every[0]
    assert "| /swarm/host_0 | accepted world | 3 |" in every
    drops = module.soak_counts(samples, "soak.png", counts, dropped_only=True)
    assert "| /swarm/host_0 | dropped world: forged | 7 |" in drops
    assert not any("accepted" in line for line in drops)


def test_the_swarm_solve_section_measures_a_small_torus_and_renders_its_rows(tmp_path):
    import json
    import subprocess
    import sys

    from swazure_ros.core.files import config_dir

    sensor = config_dir() / "cameras" / "sensor-wide-calibrated.yaml"
    done = subprocess.run(
        [sys.executable, "-m", "bench.measure_swarm_solve", "torus:150", "--beta",
         "0.5", "--sensor", str(sensor), "--outliers", "--warm"],
        capture_output=True, text=True, timeout=300, check=True,
    )  # fmt: skip
    row = json.loads(done.stdout)
    # The swarm's solve is the central fit's; it takes iterations, and a warm start fewer.
    assert row["largest_difference_cm"] < 1e-6
    assert all(count > 0 for count in row["iterations"][0])
    assert row["warm"]["departed_warm"] < row["warm"]["departed_cold"]
    row.update(shape="torus:150", sensor="wide, calibrated", beta=0.5, peak_mb=1)
    packed = [
        {"shape": "racecar_3720", "estimator": "path", "discovery": 60.0, "rounds": 40,
         "messages": 1, "engine": 1.0, "identical": "yes", "peak": 1},
        {"shape": "racecar_3720", "estimator": "swarm-fit", "discovery": 90.0, "rounds": 400,
         "messages": 1, "engine": 1.0, "identical": "yes", "peak": 1},
    ]  # fmt: skip
    lines = bench().swarm_solve_lines([row], packed)
    assert any(line.startswith("| torus:150 | wide, calibrated | 0.5 |") for line in lines)
    assert (
        "| the race car's fit by its swarm, packed, under 60 s (the fit's share, s) | "
        "1 of 1 | racecar_3720: 30.0 |" in lines
    )
