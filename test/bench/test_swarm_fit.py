"""bench.swarm_fit: the swarm's own fits' rows, made and failed."""

from bench.swarm_fit import swarm_fit_row

from .tables import cells


def test_a_swarm_fit_row_gives_the_runs_time_traffic_and_identity_or_why_it_failed():
    run = {"discovery": 61.04, "rounds": 40, "messages": 123456, "bytes": 2.5e7,
           "engine": 3.25, "identical": "yes", "peak": "812"}  # fmt: skip
    assert cells(swarm_fit_row("chess_408", "local-least-squares", run)) == [
        "chess_408", "local-least-squares", "61.0", "40", "123,456", "25", "3.2", "yes", "812",
    ]  # fmt: skip
    failed = cells(swarm_fit_row("dragon_1147", "path", {"failed": "exit 1: lost"}))
    assert len(failed) == 9 and failed[2] == "exit 1: lost"
