"""bench.soak: a small torus's swarm answering pose queries, its memory and its graph."""

from argparse import Namespace

import pytest

from bench.soak import soak_section

from .tables import check_shape


@pytest.mark.bench_section
def test_the_soak_section_answers_queries_and_samples_the_swarm_at_both_ends(domain, tmp_path):
    lines = soak_section(
        Namespace(beta=0.5), shape="torus:60", domain=domain, seconds=3.0, figures=tmp_path
    )
    assert lines[0].startswith("## Soak: a chess swarm answering queries for 0 minutes")
    answered = next(line for line in lines if line.startswith("Queries answered: "))
    assert int(answered.split(": ")[1].split(",")[0]) > 0
    assert any(line.startswith("Latency: median ") for line in lines)
    [(header, rows)] = check_shape(lines)
    assert header[:4] == ["minute", "answered", "failed", "memory (MB)"]
    assert len(rows) == 2 and int(rows[-1][1]) > 0  # start and end; queries answered
    assert all(int(row[3]) > 0 and int(row[4]) > 0 and int(row[7]) > 0 for row in rows)
    assert (tmp_path / "soak.png").read_bytes().startswith(b"\x89PNG")
