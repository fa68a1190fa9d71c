"""bench.discovery: a small torus's swarm computing every blind pair beside the engine."""

from argparse import Namespace

from bench.discovery import discovery_row, discovery_section

from .tables import cells, check_shape


def test_the_discovery_section_runs_a_small_torus_plain_and_matches_the_engine(domain):
    lines = discovery_section(
        Namespace(beta=0.5), sizes={"torus:60": 60}, techniques=("plain",), domain=domain
    )
    [(header, [row])] = check_shape(lines)
    assert header[:3] == ["shape", "technique", "processes"] and header[-2] == "identical"
    assert row[:3] == ["torus:60", "plain", "1"], row
    assert float(row[3]) > 0 and int(row[5]) > 0 and int(row[8].replace(",", "")) > 0
    assert row[6] == row[7] == "-" and row[-2] == "yes"


def test_a_heuristics_row_gives_its_moves_batches_and_timeouts():
    run = {"wall": 30.0, "peak": "400", "bring_up": 2.0, "discovery": 5.0, "rounds": 12,
           "moving": 3.0, "timeouts": 2, "batches": 1234, "messages": 5678, "bytes": 3e6,
           "engine": 0.5, "identical": "yes"}  # fmt: skip
    row = cells(discovery_row("chess_408", "move-source", 1, run))
    assert row[6:8] == ["3.0 (2 timed out)", "1,234"] and row[12] == "16.0"
