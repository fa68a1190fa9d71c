"""bench.swarm_solve: the swarm's own solve beside the central fit, and its rows."""

import json
import subprocess
import sys

from bench.swarm_solve import swarm_solve_lines
from swazure_ros.core.files import config_dir


def test_the_swarm_solve_section_measures_a_small_torus_and_renders_its_rows(tmp_path):
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
    lines = swarm_solve_lines([row], packed)
    assert any(line.startswith("| torus:150 | wide, calibrated | 0.5 |") for line in lines)
    assert (
        "| the race car's fit by its swarm, packed, under 60 s (the fit's share, s) | "
        "1 of 1 | racecar_3720: 30.0 |" in lines
    )
