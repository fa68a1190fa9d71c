"""The engine as library functions (swazure_ros.api.engine) against `swazure evaluate`."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pytest

from swazure_ros import api
from swazure_ros.core.errors import CloudError, OptionError, SwazureError
from swazure_ros.files.atomic import finite_json
from swazure_ros.files.results import write_csv

from ..conftest import dataset

# A small built-in shape: torus:120 at 1.6 x has sweet, blocked and unreachable pairs.
SHAPE = ["--cloud", "torus:120", "--scale", "1.6", "--beta", "0.5"]


def swazure_evaluate(tmp_path, *options, shape=SHAPE):
    """`swazure evaluate` of ``shape`` with ``options``: its summary.json and pairs.csv bytes."""
    out = tmp_path / "out"
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "evaluate", *shape, *options,
         "--quiet", "--out", str(out)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    return json.loads((out / "summary.json").read_text()), (out / "pairs.csv").read_bytes()


def csv_bytes(table) -> bytes:
    """``table`` as `swazure evaluate` writes pairs.csv: id lists as ids joined by spaces."""
    columns = {}
    for name in table.column_names:
        column = table[name]
        if pa.types.is_list(column.type) or pa.types.is_large_list(column.type):
            column = pc.binary_join(pc.cast(column, pa.large_list(pa.string())), " ")
        columns[name] = column
    sink = io.BytesIO()
    write_csv(pa.table(columns), sink)
    return sink.getvalue()


def without_seconds(document):
    """A summary.json document without the run's times, which differ from run to run."""
    document = dict(finite_json(document))
    document.pop("seconds")
    for part in ("fusion", "fit"):
        if part in document:
            document[part] = {k: v for k, v in document[part].items() if k != "seconds"}
    return document


@pytest.mark.parametrize(
    ("options", "keywords"),
    [
        ((), {}),  # plain: block by block, as the command line runs it
        (("--technique", "move-obstructing"), {"technique": "move-obstructing"}),
        (("--estimator", "least-squares"), {"estimator": "least-squares"}),
    ],
    ids=["plain", "move-obstructing", "least-squares"],
)
def test_evaluate_gives_the_summary_and_pairs_that_swazure_evaluate_writes(
    tmp_path, options, keywords
):
    summary, pairs_csv = swazure_evaluate(tmp_path, *options)
    result = api.evaluate(api.build_swarm("torus:120", scale=1.6, beta=0.5), **keywords)
    assert without_seconds(result.summary.as_document()) == without_seconds(summary)
    assert result.record.summary is result.summary
    assert result.pairs.num_rows == summary["blind_pairs"] > 1000
    assert csv_bytes(result.pairs) == pairs_csv


def test_a_swarm_without_blind_pairs_gives_an_empty_table_with_every_column(tmp_path):
    path = tmp_path / "far.npy"
    np.save(path, [[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0]])
    summary, pairs_csv = swazure_evaluate(
        tmp_path, shape=["--cloud", str(path), "--radius", "0.5"]
    )
    result = api.evaluate(api.build_swarm(path, radius=0.5))
    assert result.pairs.num_rows == summary["blind_pairs"] == 0
    assert without_seconds(result.summary.as_document()) == without_seconds(summary)
    assert csv_bytes(result.pairs) == pairs_csv and pairs_csv.startswith(b'"source","target"')


def test_the_heuristics_by_name_are_evaluate_with_their_technique():
    setup = api.build_swarm("torus:120", scale=1.6, beta=0.5)
    moved = api.move_source(setup, threshold=3)
    asked = api.evaluate(setup, technique="move-source", threshold=3)
    assert moved.summary.heuristic is not None and moved.summary.heuristic.threshold == 3
    assert moved.summary.heuristic.resolved_pairs == asked.summary.heuristic.resolved_pairs > 0
    assert moved.pairs["resolved"].to_pylist() == asked.pairs["resolved"].to_pylist()
    obstructing = api.move_obstructing(setup).summary.heuristic
    assert obstructing is not None and obstructing.technique == "move-obstructing"


def test_a_swarm_from_an_array_is_the_swarm_of_the_same_points_from_a_file(tmp_path):
    points = api.cloud_of("torus:120", scale=1.6).points
    path = tmp_path / "torus.npy"
    np.save(path, points)
    from_array = api.evaluate(api.build_swarm(points, beta=0.5))
    from_file = api.evaluate(api.build_swarm(path, beta=0.5))
    assert from_array.setup.cloud.source == "array"
    assert csv_bytes(from_array.pairs) == csv_bytes(from_file.pairs)


def test_a_published_cloud_by_its_short_name():
    path = dataset("chess_408.xyz")
    setup = api.build_swarm("chess", beta=0.5)
    assert setup.cloud.source == str(path) and setup.cloud.scale == 13.6


@pytest.mark.parametrize(
    ("cloud", "message"),
    [
        ("no-such-shape", "unknown shape 'no-such-shape'"),
        ("dragonfly", "published cloud \\(chess_408"),
        (np.zeros((5, 2)), r"expected 3 coordinates per point, got an array of shape \(5, 2\)"),
        ([[0.0, 0.0, 0.0], [1.0, np.nan, 0.0]], "point 1 has a NaN"),
        (np.array([["a", "b", "c"], ["d", "e", "f"]]), "coordinates must be real numbers"),
        ("/no/such/file.xyz", "no such file"),
    ],
    ids=["unknown-shape", "unknown-name", "two-columns", "nan", "text", "no-file"],
)
def test_a_cloud_that_cannot_be_used_is_a_cloud_error(cloud, message):
    with pytest.raises(CloudError, match=message):
        api.build_swarm(cloud, beta=0.5)


@pytest.mark.parametrize(
    ("sizes", "message"),
    [({"beta": 0.5, "radius": 1.0}, "not both"), ({}, "give beta"), ({"beta": 2.0}, "beta")],
)
def test_beta_and_radius_one_of_them_in_range(sizes, message):
    with pytest.raises(CloudError, match=message):
        api.build_swarm("torus:120", **sizes)


@pytest.mark.parametrize(
    ("keywords", "kind", "message"),
    [
        ({"policy": "shortest"}, OptionError, "policy 'shortest': expected one of"),
        ({"technique": "move-all"}, OptionError, "technique 'move-all'"),
        ({"estimator": "kalman"}, OptionError, "estimator 'kalman'"),
        ({"compat": "old"}, OptionError, "compat 'old'"),
        ({"threshold": 0}, OptionError, "threshold 0: must be 1 to 1000"),
        ({"fuse": 2.5}, OptionError, "fuse must be a whole number"),
        ({"technique": "move-source", "fuse": 2}, SwazureError, "drop --technique"),
        ({"compat": "published"}, SwazureError, "add --technique"),
    ],
)
def test_evaluate_refuses_options_with_the_error_of_the_house(keywords, kind, message):
    setup = api.build_swarm("torus:120", scale=1.6, beta=0.5)
    with pytest.raises(kind, match=message):
        api.evaluate(setup, **keywords)


def test_evaluate_asks_for_a_built_swarm_not_a_cloud():
    with pytest.raises(OptionError, match="build_swarm"):
        api.evaluate("torus:120")  # type: ignore[arg-type]


def test_a_sensor_given_as_an_object_is_named_so_in_the_summary():
    setup = api.build_swarm("torus:120", scale=1.6, beta=0.5)
    given = api.build_swarm("torus:120", scale=1.6, beta=0.5, sensor=setup.sensor)
    source = api.evaluate(given).summary.parameters.source
    assert source is not None and source.sensor_file == "(a Sensor given in Python)"


def test_importing_the_api_loads_no_ros():
    # A notebook that only evaluates needs no ROS 2; the client loads rclpy when it connects.
    check = subprocess.run(
        [sys.executable, "-c", "import sys, swazure_ros.api; print('rclpy' in sys.modules)"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert check.returncode == 0, check.stderr
    assert check.stdout.strip() == "False"
