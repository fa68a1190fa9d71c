"""bench.faults: a small torus's discovery under a lossy radio, stopped FLSs, a lost leader."""

from argparse import Namespace

import pytest

from bench.faults import faults_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_faults_section_gives_a_row_per_case_and_the_perfect_radio_matches_the_engine(
    domain, tmp_path
):
    lines = faults_section(
        Namespace(beta=0.5), shape="torus:60", domain=domain, records_dir=tmp_path
    )
    [(header, rows)] = check_shape(lines)
    assert header[:2] == ["case", "wall s"]
    assert [row[0] for row in rows] == [
        "perfect radio", "10 % of deliveries lost", "10 % lost, each message up to 50 ms late",
        "3 FLS nodes (5 %) stopped mid-run", "coordinator lost mid-run",
    ]  # fmt: skip
    perfect = rows[0]
    assert int(perfect[2]) > 0 and int(perfect[4]) > 0  # rounds, messages
    identical, of = perfect[6].split(" pairs identical")[0].split(" of ")
    assert identical == of and int(of) > 0
    assert "ABORTED" in rows[4][6]
