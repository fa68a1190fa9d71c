"""bench.exits: a per-FLS swarm stopped by Ctrl-C under each launcher; the table of how
each process ended, and how long a live peer listed the stopped swarm's nodes."""

from argparse import Namespace

import pytest

from bench.exits import (
    KINDS,
    LAUNCH,
    LAUNCH_PIPED,
    SPAWN,
    End,
    Run,
    exits_lines,
    exits_section,
    launchers,
)

from .tables import check_shape


@pytest.mark.bench_section
def test_the_exits_section_tables_how_every_process_of_each_launcher_ended(domain):
    # One run under each launcher: the table's sums over runs are test_..._sum_every_run's.
    lines = exits_section(Namespace(beta=0.5), runs=1, linger_runs=1, domain=domain)
    assert lines[:3] == ["## Under load", "", "### Exits over 100 runs"]
    [(header, rows)] = check_shape(lines)
    assert header[:4] == ["launcher", "process", "ends", "exit 0"]
    measured = [launcher for launcher, _ in launchers()]
    launched = ["launch", "world", "coordinator", "fls"]
    expected = {LAUNCH: launched, LAUNCH_PIPED: launched, SPAWN: ["spawn", "fls"]}
    assert [(row[0], row[1]) for row in rows] == [
        (launcher, KINDS[kind]) for launcher in measured for kind in expected[launcher]
    ]
    for row in rows:
        ends = int(row[2])
        # One run: the launcher, the world and the coordinator once, the trio's FLSs thrice.
        assert ends == (3 if row[1] == "FLS" else 1), row
        assert 0 <= int(row[3]) <= ends and 0 <= float(row[8]) <= float(row[9]), row
    for launcher in measured:
        [facts] = [line for line in lines if line.startswith(f"{launcher}: ")]
        assert facts.startswith(f"{launcher}: 1 of 1 runs came up;"), facts
        assert "A participant alive beside the swarm listed" in facts, facts


def test_the_exits_table_and_facts_sum_every_run_of_a_launcher():
    # Two runs of `swazure spawn --per-fls`: the second's FLS 2 killed, a file left.
    def run(fls_2_code: int, left: list[str]) -> Run:
        ends = [End(SPAWN, "spawn", 0, False, 0.5)]
        ends += [End(SPAWN, "fls", code, False, 1.0) for code in (0, 0, fls_2_code)]
        return Run(ends, left, died_lines=0)

    results: dict[str, list[Run | None]] = {SPAWN: [run(0, []), run(-9, ["x.log"]), None]}
    lines = exits_lines(results, {SPAWN: [(0.5, 0)]}, [1.0, 2.0, 3.0])
    [(_, rows)] = check_shape(lines)
    assert [row[:6] for row in rows] == [
        [SPAWN, KINDS["spawn"], "2", "2", "0", "0"],
        [SPAWN, KINDS["fls"], "6", "5", "0", "1 (SIGKILL ×1)"],
    ]
    [facts] = [line for line in lines if line.startswith(f"{SPAWN}: ")]
    assert facts.startswith(f"{SPAWN}: 2 of 3 runs came up; in 1 a process did not end"), facts
    assert "and 1 left a file behind (x.log)." in facts, facts
