"""Move Source's body rule (``source_body``): the source's own body at its probe point
may hide the target from the helper, as the swarm flies it; the spec's rule does not
check it (docs/protocol.md)."""

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.core.evaluate import evaluate
from swazure_ros.core.evaluation import REASON_BLOCKED
from swazure_ros.core.geometry import make_swarm
from swazure_ros.core.heuristics.result import MOVE_SOURCE
from swazure_ros.core.heuristics.source import (
    DIRECTIONS,
    move_source,
    source_body_in_the_way,
)
from swazure_ros.core.pipeline import RunOptions, run_engine

from ..conftest import source_body_scene

R = 0.5


def body_scene_evaluation(sensor):
    swarm = make_swarm(source_body_scene(), radius=R)
    return swarm, evaluate(swarm, sensor, "shortest-length")


def test_the_source_s_body_at_its_probe_is_checked_only_with_the_option(sensor):
    swarm, plain = body_scene_evaluation(sensor)
    pairs = plain.pairs
    m = int(np.flatnonzero((pairs.source == 0) & (pairs.target == 2))[0])
    assert pairs.reason[m] == REASON_BLOCKED
    spec = move_source(plain, threshold=10)
    checked = move_source(plain, threshold=10, source_body=True)
    # The spec's rule: the first probe, 3 r along the first direction, via helper 1,
    # though the source standing there is on the segment from 1 to 2.
    assert spec.resolved[m] and spec.paths.path(m) == [0, 1, 2]
    [(_, _, at)] = spec.moves(m)
    np.testing.assert_allclose(at, 3 * R * DIRECTIONS[0], atol=1e-12)
    assert source_body_in_the_way(spec, swarm).tolist() == [m]
    # With the option that probe fails for helper 1, and the next direction succeeds.
    assert checked.resolved[m] and checked.paths.path(m) == [0, 1, 2]
    [(_, _, at)] = checked.moves(m)
    np.testing.assert_allclose(at, 3 * R * DIRECTIONS[1], atol=1e-12)
    assert source_body_in_the_way(checked, swarm).tolist() == []
    # Every other pair is as it was.
    others = np.arange(len(pairs)) != m
    np.testing.assert_array_equal(spec.tried, checked.tried)
    np.testing.assert_array_equal(spec.resolved[others], checked.resolved[others])
    assert checked.source_body and not spec.source_body


def test_the_option_is_in_the_summary_only_when_asked(sensor):
    swarm, _ = body_scene_evaluation(sensor)
    spec = run_engine(swarm, sensor, RunOptions(technique=MOVE_SOURCE))
    checked = run_engine(swarm, sensor, RunOptions(technique=MOVE_SOURCE, source_body=True))
    assert "source_body" not in spec.summary.as_document()
    assert "source_body" not in spec.summary.as_document()["parameters"]
    document = checked.summary.as_document()
    assert document["source_body"] is True and document["parameters"]["source_body"] is True
    assert type(checked.summary).from_document(document) == checked.summary


def test_the_option_goes_with_move_source_only(sensor):
    swarm, _ = body_scene_evaluation(sensor)
    with pytest.raises(SwazureError, match="--source-body changes Move Source"):
        run_engine(swarm, sensor, RunOptions(source_body=True))
