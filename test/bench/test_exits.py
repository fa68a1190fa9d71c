"""bench.exits: a per-FLS swarm stopped by Ctrl-C, run twice under each launcher; the table of
how each process ended, and how long a live peer listed the stopped swarm's nodes."""

from argparse import Namespace

from bench.exits import KINDS, LAUNCH, LAUNCH_PIPED, SPAWN, exits_section, launchers

from .tables import check_shape


def test_the_exits_section_tables_how_every_process_of_each_launcher_ended(domain):
    lines = exits_section(Namespace(beta=0.5), runs=2, linger_runs=1, domain=domain)
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
        # Two runs: the launcher once a run, the world and the coordinator once, FLSs thrice.
        assert ends == (6 if row[1] == "FLS" else 2), row
        assert 0 <= int(row[3]) <= ends and 0 <= float(row[8]) <= float(row[9]), row
    for launcher in measured:
        [facts] = [line for line in lines if line.startswith(f"{launcher}: ")]
        assert facts.startswith(f"{launcher}: 2 of 2 runs came up;"), facts
        assert "A participant alive beside the swarm listed" in facts, facts
