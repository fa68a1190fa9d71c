"""bench.under_load: a small packed torus and the trio in FLS processes beside a busy loop."""

from argparse import Namespace

import pytest

from bench.under_load import SHORT_LEASE, under_load_section

from ..conftest import REPO
from .tables import check_shape


@pytest.mark.bench_section
def test_the_under_load_section_loses_no_fls_and_takes_every_fls_back(domain):
    lines = under_load_section(
        Namespace(beta=0.5),
        packed="torus:60",
        grid=REPO / "config" / "track" / "trio.xyz",
        runs=1,
        fls=1,  # the trio's relay: FLS 0 sees FLS 2 through it
        stops=(("stopped 8 s past a 5 s lease", SHORT_LEASE, 8.0),),
        loops=1,
        domain=domain,
    )

    [(header, rows), (back_header, back)] = check_shape(lines)
    assert header[:3] == ["swarm", "processes", "busy loops"]
    assert [row[:3] for row in rows] == [
        ["torus:60", "2", "0"], ["torus:60", "2", "1"], ["trio", "4", "0"], ["trio", "4", "1"],
    ]  # fmt: skip
    named = dict(zip(header, zip(*rows, strict=True), strict=True))
    assert set(named["departed"]) == {"0"}
    assert named["identical"][:2] == ("yes", "yes")
    assert set(named["identical"][2:]) == {"2 of 2 pairs identical"}
    assert back_header[:2] == ["case", "gone after s"]
    assert [row[0] for row in back] == ["stopped 8 s past a 5 s lease", "killed, started again"]
    for row in back:
        assert row[4] == "none" and row[5] == "2 of 2 pairs identical", row
