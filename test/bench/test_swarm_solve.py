"""bench.swarm_solve: the swarm's own solve beside the central fit on a small torus."""

import json
from argparse import Namespace

from bench.least_squares import FIT_SENSORS
from bench.swarm_solve import swarm_solve_lines, swarm_solve_section

from .tables import check_shape


def test_the_swarm_solve_section_measures_a_small_torus_and_renders_its_rows(tmp_path):
    wide = {"wide, calibrated": FIT_SENSORS["wide, calibrated"]}
    lines = swarm_solve_section(
        Namespace(beta=0.5), shapes=("torus:150",), sensors=wide, betas=(0.5,), large=(),
        packed_shapes=(), figures=tmp_path, records_dir=tmp_path,
    )  # fmt: skip
    [row] = json.loads((tmp_path / "swarm-solve.json").read_text())["rows"]
    # The swarm's solve is the central fit's; it takes iterations, and a warm start fewer.
    assert row["largest_difference_cm"] < 1e-6
    assert all(count > 0 for count in row["iterations"][0])
    assert row["warm"]["departed_warm"] < row["warm"]["departed_cold"]
    fits, warm, outliers, packed, targets = check_shape(lines)
    assert fits[1][0][:3] == ["torus:150", "wide, calibrated", "0.5"]
    assert warm[1][0][0] == "torus:150" and int(warm[1][0][2]) > 0  # cold iterations
    assert outliers[1][0][0] == "torus:150" and packed[1] == []
    assert len(targets[1]) == 7
    assert (tmp_path / "swarm-solve.png").read_bytes().startswith(b"\x89PNG")
    packed = [
        {"shape": "racecar_3720", "estimator": "path", "discovery": 60.0, "rounds": 40,
         "messages": 1, "engine": 1.0, "identical": "yes", "peak": 1},
        {"shape": "racecar_3720", "estimator": "swarm-fit", "discovery": 90.0, "rounds": 400,
         "messages": 1, "engine": 1.0, "identical": "yes", "peak": 1},
    ]  # fmt: skip
    lines = swarm_solve_lines([row], packed)
    assert (
        "| the race car's fit by its swarm, packed, under 60 s (the fit's share, s) | "
        "1 of 1 | racecar_3720: 30.0 |" in lines
    )
