"""Run records: record.json reads back as the record written, a version 1 record too;
another version is refused."""

import json
from dataclasses import replace

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.files.record import (
    RECORD_FILE,
    RECORD_VERSION,
    BringUp,
    Distributed,
    EngineComparison,
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
        comparison=EngineComparison(7208, 7208),
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
    version = f'"fileversion": {RECORD_VERSION}'
    path.write_text(path.read_text().replace(version, '"fileversion": 99'))
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


@pytest.fixture
def swarm_run(sensor) -> RunRecord:
    """A swarm's run beside the engine's, its pairs the engine's."""
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm

    summary = evaluate(make_swarm(np.array(SCENE), radius=0.5), sensor, "shortest-length").summary
    found = summary.pairs.blind_pairs
    distributed = Distributed(2.75, 9, 0, [], {"radio": 40}, {"radio": 4000})
    comparison = EngineComparison(found, found)
    return RunRecord("spawn", 2.75, summary, summary, 0.5, comparison, distributed=distributed)


@pytest.mark.parametrize(
    ("comparison", "text"),
    [
        (EngineComparison(12, 12), "yes"),
        (EngineComparison(12, 12, 1, 0, False),
         "1 statuses, 0 estimates differ; paths differ: False"),
        (EngineComparison(12, 12, 0, 1, False),
         "0 statuses, 1 estimates differ; paths differ: False"),
        (EngineComparison(12, 12, 0, 0, True),
         "0 statuses, 0 estimates differ; paths differ: True"),
        (EngineComparison(12, 13, None, None, None), "12 pairs reported, the engine has 13"),
    ],
)  # fmt: skip
def test_a_comparison_is_identical_only_when_no_pair_differs(comparison, text):
    identical = text == "yes"
    assert comparison.identical == identical
    assert comparison.describe() == (text if identical else f"no: {text}")


@pytest.mark.parametrize(
    "comparison",
    [
        EngineComparison(12, 12),
        EngineComparison(12, 12, 0, 3, False),
        EngineComparison(12, 12, 2, 0, True),
        EngineComparison(0, 12, None, None, None),
    ],
)
def test_the_comparison_with_the_engine_is_a_record_in_record_json(
    tmp_path, swarm_run, comparison
):
    path = write_record(tmp_path, replace(swarm_run, comparison=comparison))
    document = json.loads(path.read_text())
    assert document["comparison"] == {
        "identical": comparison.identical, "pairs": comparison.pairs,
        "engine_pairs": comparison.engine_pairs, "statuses": comparison.statuses,
        "estimates": comparison.estimates, "paths": comparison.paths,
    }  # fmt: skip
    assert "identical" not in document and read_record(path).comparison == comparison


def test_a_comparison_whose_identical_is_not_its_counts_is_refused(tmp_path, swarm_run):
    path = write_record(tmp_path, swarm_run)
    document = json.loads(path.read_text())
    document["comparison"]["statuses"] = 1  # identical still says true
    path.write_text(json.dumps(document))
    with pytest.raises(SwazureError, match=r"not a run record .*identical True, but its counts"):
        read_record(path)


def version_1(path, identical):
    """Make the record at ``path`` the version 1 record of the same run: its comparison as
    the text ``identical`` held."""
    document = json.loads(path.read_text())
    document["identical"] = identical
    del document["comparison"]
    document["fileversion"] = 1
    path.write_text(json.dumps(document))


@pytest.mark.parametrize(
    ("text", "statuses", "estimates", "paths", "differ"),
    [
        ("yes", 0, 0, False, False),
        ("no: 3 statuses, 0 estimates differ; paths differ: True", 3, 0, True, False),
        ("no: 0 statuses, 5 estimates differ; paths differ: False", 0, 5, False, False),
        ("no: 0 pairs reported, the engine has 12", None, None, None, True),
    ],
)
def test_a_version_1_record_comes_back_with_its_text_as_a_comparison(
    tmp_path, swarm_run, text, statuses, estimates, paths, differ
):
    path = write_record(tmp_path, swarm_run)
    version_1(path, text)
    back = read_record(path)
    # The counts the text does not say are the summaries' blind pairs, the run's and the
    # engine's; the rest is as it was, in this version's record.
    found = swarm_run.summary.pairs.blind_pairs
    pairs = (0, 12) if differ else (found, found)
    assert back.comparison == EngineComparison(*pairs, statuses, estimates, paths)
    assert back.comparison.describe() == text
    assert back == replace(swarm_run, comparison=back.comparison)
    assert back.fileversion == RECORD_VERSION


def test_a_version_1_record_of_no_comparison_or_another_text_reads_so(tmp_path, swarm_run):
    path = write_record(tmp_path, swarm_run)
    version_1(path, None)
    assert read_record(path).comparison is None
    for text in ("no", "yes, mostly", 1):
        version_1(write_record(tmp_path, swarm_run), text)
        with pytest.raises(SwazureError, match="not a run record"):
            read_record(path)
    # "yes" in a record without the summaries that say how many pairs: not a record.
    version_1(write_record(tmp_path, replace(swarm_run, engine=None)), "yes")
    with pytest.raises(SwazureError, match=r"not a run record .*without the run's and the"):
        read_record(path)


def test_a_swarm_runs_record_is_built_from_the_runs_results_as_record_json_held_it(sensor):
    """Distributed.of takes the protocol's results; its document is record.json's, key for key."""
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
    found = Outcome(
        {}, frozenset({7, 3}), rounds=9, restarts=1, repairs=2, incomplete=True, label_bytes=5000
    )
    traffic = Traffic({"radio": 40, "estimates": 5}, {"radio": 4000})
    discovery = DiscoveryResult(1, "shortest-length", found, 2.75, traffic, runs=3)
    made = MoveOutcome(moved, heuristic, batches=3, moved=12, walks=4, timeouts=1)
    moves = MoveResult(2, made, 1.5, Traffic({"move_commands": 3}, {"move_commands": 900}))
    distributed = Distributed.of(discovery, moves)
    # The layout record.json has held since its first version, in its order; what came
    # later (the labels' memory, the runs of source blocks) after it.
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
            "label_bytes": 5000, "runs": 3,
        }
    )  # fmt: skip
    assert Distributed.of(discovery).moves is None
    # A copy: counting on after the run changes nothing in its record.
    discovery.traffic.count("radio", 100)
    assert distributed.messages["radio"] == 40 and distributed.total_messages == 48
