"""bench.swarm: a small torus served, at rest and under a heartbeat, then torn down."""

from argparse import Namespace

import pytest

from bench.swarm import served_row, swarm_section

from .tables import cells, check_shape


@pytest.mark.bench_section
def test_the_swarm_section_serves_a_small_torus_and_counts_its_messages(domain):
    lines = swarm_section(
        Namespace(beta=0.5), sizes={"torus:60": 60}, domain=domain, processes=(1,), window=2.0
    )
    [(_, [served]), (_, [rate])] = check_shape(lines)
    assert served[:3] == ["torus:60", "60", "1"]
    assert float(served[3]) > 0 and served[4].endswith(")") and float(served[6]) > 0
    assert rate[:4] == ["torus:60", "60", "1", "600"] and int(rate[4].replace(",", "")) > 0


def test_a_swarm_that_did_not_come_up_says_so_in_its_row():
    row = {"failed": "not up in 15 min", "teardown": 0.5}
    assert cells(served_row("racecar_3720", 3720, 2, row)) == [
        "racecar_3720", "3720", "2", "not up in 15 min", "", "", "0.5",
    ]  # fmt: skip
