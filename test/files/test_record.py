"""Run records: record.json reads back as the record written; another version is refused."""

from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.files.record import (
    RECORD_FILE,
    BringUp,
    Distributed,
    MovesMade,
    RunRecord,
    read_record,
    write_record,
)

from ..conftest import SCENE


def test_a_run_record_reads_back_as_it_was_written(tmp_path, sensor):
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm

    evaluation = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")
    engine = replace(evaluation.summary, seconds=4.25)
    alpha = replace(engine.pairs.alpha_deg, mean=float("nan"))
    moves = MovesMade(1.5, 3, 12, 4, 0, {"move_commands": 3}, {"move_commands": 900})
    record = RunRecord(
        "spawn",
        4.25,
        replace(engine, pairs=replace(engine.pairs, alpha_deg=alpha)),
        engine=engine,
        engine_seconds=0.5,
        identical="yes",
        bring_up=BringUp(120, 2, 3.5, [300.0, 250.0]),
        distributed=Distributed(2.75, 9, 0, [7], {"radio": 40}, {"radio": 4000}, moves=moves),
    )
    path = write_record(tmp_path, record)
    assert path == tmp_path / RECORD_FILE
    back = read_record(path)
    # NaN is written as null (JSON has no NaN): everything else comes back as it was.
    assert back.summary.pairs.alpha_deg.mean is None
    assert back == RunRecord(**{**record.__dict__, "summary": back.summary})
    assert back.distributed.total_messages == 43 and back.bring_up.total_peak_mb == 550.0


def test_a_record_of_another_version_or_no_record_is_refused_in_one_line(tmp_path):
    path = write_record(tmp_path, RunRecord("evaluate", 1.0, None))
    path.write_text(path.read_text().replace('"fileversion": 1', '"fileversion": 99'))
    with pytest.raises(SwazureError, match="fileversion 99"):
        read_record(path)
    (tmp_path / "other.json").write_text("[1, 2]")
    with pytest.raises(SwazureError, match="fileversion None"):
        read_record(tmp_path / "other.json")
    with pytest.raises(SwazureError, match="no such run record file"):
        read_record(tmp_path / "missing.json")
    # A record of this version whose summary is not one: one line, not a KeyError.
    path = write_record(tmp_path, RunRecord("evaluate", 1.0, None))
    path.write_text(path.read_text().replace('"summary": {}', '"summary": {"flss": 3}'))
    with pytest.raises(SwazureError, match="not a run record"):
        read_record(path)


def test_a_swarm_runs_record_is_built_from_the_runs_results_as_record_json_held_it(sensor):
    """Distributed.of takes the protocol's results; its document is record.json's, key for key."""
    import json
    from dataclasses import asdict

    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.core.heuristics.folding import run_technique
    from swazure_ros.protocol.moves import MoveOutcome
    from swazure_ros.protocol.rounds import Outcome
    from swazure_ros.protocol.runs import DiscoveryResult, MoveResult, Traffic

    plain = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length")
    moved, heuristic = run_technique(plain, "move-obstructing")
    assert heuristic is not None
    found = Outcome({}, frozenset({7, 3}), rounds=9, restarts=1, repairs=2, incomplete=True)
    discovery = DiscoveryResult(
        1, "shortest-length", found, 2.75, Traffic({"radio": 40, "estimates": 5}, {"radio": 4000})
    )
    made = MoveOutcome(moved, heuristic, batches=3, moved=12, walks=4, timeouts=1)
    moves = MoveResult(2, made, 1.5, Traffic({"move_commands": 3}, {"move_commands": 900}))
    distributed = Distributed.of(discovery, moves)
    # The layout record.json has held since its first version, in its order.
    assert json.dumps(asdict(distributed)) == json.dumps(
        {
            "seconds": 2.75, "rounds": 9, "restarts": 1, "departed": [3, 7],
            "messages": {"radio": 40, "estimates": 5}, "bytes": {"radio": 4000},
            "repairs": 2, "incomplete": True,
            "moves": {
                "seconds": 1.5, "batches": 3, "move_commands": 12, "path_walks": 4,
                "timeouts": 1, "messages": {"move_commands": 3},
                "bytes": {"move_commands": 900},
            },
        }
    )  # fmt: skip
    assert Distributed.of(discovery).moves is None
    # A copy: counting on after the run changes nothing in its record.
    discovery.traffic.count("radio", 100)
    assert distributed.messages["radio"] == 40 and distributed.total_messages == 48
