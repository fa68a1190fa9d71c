"""bench.engine: `swazure evaluate` timed on a small torus, plain and with a heuristic."""

from argparse import Namespace

from bench.engine import engine_section


def rows_of(lines: list[str], first: str) -> list[list[str]]:
    """The cells of the table rows of ``lines`` that start with ``first``."""
    return [[cell.strip() for cell in line.split("|")[1:-1]] for line in lines
            if line.startswith(f"| {first} |")]  # fmt: skip


def test_the_engine_section_times_each_policy_and_heuristic_on_a_small_torus():
    lines = engine_section(
        Namespace(beta=0.5), shapes=("torus:120",), policies=("shortest-length",),
        heuristics=(("move-source", 2),),
    )  # fmt: skip
    assert lines[0].startswith("## Core engine") and any(
        x.startswith("## Heuristics") for x in lines
    )
    plain, heuristic = rows_of(lines, "torus:120")
    assert len(plain) == 10 and plain[1] == "shortest-length" and plain[2] == "120"
    assert int(plain[3].replace(",", "")) > 0 and float(plain[7]) > 0  # blind pairs, wall s
    assert len(heuristic) == 13 and heuristic[1:3] == ["move-source", "2"]
    assert float(heuristic[11]) > 0
