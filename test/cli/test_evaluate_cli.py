"""``swazure evaluate`` in a real process: outputs, and one clear line for each bad input."""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

from swazure_ros.core.errors import SwazureError
from swazure_ros.files.record import RECORD_FILE, RECORD_VERSION, read_record
from swazure_ros.files.results import pairs_size_warning, read_pairs

from ..files.test_results import same_table


def swazure(*args, cwd=None, env=None):
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=cwd,
        env=None if env is None else {**os.environ, **env},
    )


def test_version_and_help():
    assert swazure("--version").stdout.strip().startswith("swazure ")
    help_text = swazure("--help").stdout
    assert "evaluate" in help_text
    assert "--policy" in swazure("evaluate", "--help").stdout


def test_evaluate_writes_summary_and_pairs(tmp_path):
    run = swazure(
        "evaluate",
        "--cloud",
        "sphere:150",
        "--beta",
        "0.4",
        "--policy",
        "fewest-hops",
        "--out",
        str(tmp_path),
    )
    assert run.returncode == 0, run.stderr
    assert "ordered blind pairs" in run.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    for key in (
        "flss",
        "removed",
        "radius",
        "dmin",
        "kissing_pairs",
        "blind_pairs",
        "sweet_pct",
        "decaying_pct",
        "no_path_pct",
        "blocked_pairs",
        "no_sweet_path_pairs",
        "obstructed_path_pct",
        "seconds",
        "parameters",
    ):
        assert key in summary
    for key in ("distance_error_pct", "alpha_deg", "theta_deg", "phi_deg", "hops"):
        assert set(summary[key]) >= {"mean", "max"}
    # The run as typed data: the same summary, the run's seconds, the file's version.
    record = read_record(tmp_path / RECORD_FILE)
    assert (record.command, record.fileversion) == ("evaluate", RECORD_VERSION)
    assert record.summary.as_document() == summary and record.seconds == summary["seconds"]
    assert record.engine is None and record.distributed is None
    rows = (tmp_path / "pairs.csv").read_text().splitlines()
    assert len(rows) == summary["blind_pairs"] + 1
    assert summary["parameters"]["policy"] == "fewest-hops"
    assert not list(tmp_path.glob(".*"))  # no temporary file left behind


def write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


SENSOR_OUT_OF_ORDER = """fileversion: 1
sensor:
  ranges: {sweet_min: 8, sweet_max: 6, decaying_min: 8, decaying_max: 30}
"""
SENSOR_NEGATIVE = SENSOR_OUT_OF_ORDER.replace(
    "sweet_min: 8, sweet_max: 6", "sweet_min: -2, sweet_max: 6"
)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["--cloud", "{tmp}/absent.xyz", "--beta", "0.5"], "no such file"),
        (["--cloud", "{tmp}/binary.xyz", "--beta", "0.5"], "not a text file"),
        (["--cloud", "{tmp}/columns.xyz", "--beta", "0.5"], "line 2 has 2 columns, expected 3"),
        (["--cloud", "{tmp}/nan.xyz", "--beta", "0.5"], "NaN or infinite"),
        (["--cloud", "{tmp}/one.xyz", "--beta", "0.5"], "at least two points"),
        (["--cloud", "{tmp}/duplicate.xyz", "--beta", "0.5"], "duplicate points"),
        (["--cloud", "torus", "--beta", "0"], "beta must be in (0, 1]"),
        (["--cloud", "torus", "--beta", "1.5"], "beta must be in (0, 1]"),
        (["--cloud", "torus"], "give --beta"),
        (
            ["--cloud", "torus", "--beta", "0.5", "--sensor", "{tmp}/order.yaml"],
            "ranges out of order",
        ),
        (
            ["--cloud", "torus", "--beta", "0.5", "--sensor", "{tmp}/negative.yaml"],
            "sweet_min must be above 0",
        ),
        (["--cloud", "torus", "--beta", "0.5", "--sensor", "{tmp}/broken.yaml"], "not valid YAML"),
        (["--cloud", "dodecahedron", "--beta", "0.5"], "unknown shape 'dodecahedron'"),
        (["--cloud", "torus", "--beta", "0.5", "--policy", "widest"], "invalid choice"),
        (["--cloud", "torus", "--beta", "0.5", "--memory", "lots"], "not a memory size"),
        (["--cloud", "torus", "--beta", "0.5", "--memory", "1M"], "give at least 64M"),
        # Issue 66: a budget of 1e99 bytes was taken without a word.
        (["--cloud", "torus", "--beta", "0.5", "--memory", "1e99"], "more than this machine's"),
        (["--cloud", "torus", "--beta", "0.5", "--memory", "100T"], "more than this machine's"),
    ],
)
def test_bad_input_gives_one_line_and_exit_code_2(tmp_path, arguments, message):
    (tmp_path / "binary.xyz").write_bytes(b"\xff\xfe\x00\x81" * 10)
    write(tmp_path, "columns.xyz", "1 2 3\n4 5\n")
    write(tmp_path, "nan.xyz", "1 2 3\nnan 2 3\n")
    write(tmp_path, "one.xyz", "1 2 3\n")
    write(tmp_path, "duplicate.xyz", "1 2 3\n1 2 3\n4 5 6\n")
    write(tmp_path, "order.yaml", SENSOR_OUT_OF_ORDER)
    write(tmp_path, "negative.yaml", SENSOR_NEGATIVE)
    write(tmp_path, "broken.yaml", "fileversion: [1\n")
    run = swazure("evaluate", *[a.format(tmp=tmp_path) for a in arguments])
    assert run.returncode == 2
    assert message in run.stderr
    assert "Traceback" not in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr


def test_a_run_in_small_blocks_writes_the_files_of_a_run_in_one_block(tmp_path):
    runs = {}
    for memory in ("64M", "4G"):
        out = tmp_path / memory
        run = swazure(
            "evaluate", "--cloud", "torus:1000", "--beta", "0.5", "--memory", memory,
            "--out", str(out), "--quiet",
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        summary = json.loads((out / "summary.json").read_text())
        runs[memory] = (out / "pairs.csv").read_bytes(), summary
    (small, small_summary), (large, large_summary) = runs["64M"], runs["4G"]
    assert small == large
    # 358,116 pairs: past 64M's exact values (299,593), quantiles are sketched; counts stay.
    assert small_summary["quantiles"].startswith("sketched")
    assert large_summary["quantiles"] == "exact"
    for key in ("blind_pairs", "sweet_pairs", "decaying_pairs", "sweet_neighbour_pairs"):
        assert small_summary[key] == large_summary[key]
    small_error, large_error = (
        run["distance_error_pct"] for run in (small_summary, large_summary)
    )
    assert small_error["max"] == large_error["max"]
    assert small_error["p50"] == pytest.approx(large_error["p50"], rel=1e-3)


def test_colliding_flss_are_removed_and_reported(tmp_path):
    run = swazure("evaluate", "--cloud", "cube:64", "--beta", "0.9", "--out", str(tmp_path))
    assert run.returncode == 0, run.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["removed"] > 0
    assert summary["flss"] + summary["removed"] == 64


@pytest.mark.parametrize("technique", ["move-obstructing", "move-source"])
def test_technique_adds_heuristic_fields_and_columns(tmp_path, technique):
    run = swazure(
        "evaluate",
        "--cloud",
        "torus:300",
        "--beta",
        "0.5",
        "--technique",
        technique,
        "--threshold",
        "2",
        "--out",
        str(tmp_path),
    )
    assert run.returncode == 0, run.stderr
    assert technique in run.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["technique"] == technique
    assert summary["tried_pairs"] >= summary["resolved_pairs"] > 0
    assert set(summary["moved_distance"]) >= {"mean", "max", "count"}
    if technique == "move-source":
        assert summary["threshold"] == 2
        assert set(summary["flown_distance"]) >= {"mean", "max"}
    header = (tmp_path / "pairs.csv").read_text().splitlines()[0]
    for column in ("tried", "resolved", "moves", "moved_flss", "largest_move"):
        assert f'"{column}"' in header


def test_threshold_must_be_positive():
    run = swazure(
        "evaluate",
        "--cloud",
        "torus",
        "--beta",
        "0.5",
        "--technique",
        "move-source",
        "--threshold",
        "0",
    )
    assert run.returncode == 2
    assert "argument --threshold: 0: must be 1 to 1000 steps of r" in run.stderr


def test_evaluate_with_the_least_squares_estimator_writes_covariances(tmp_path):
    sensor = "config/cameras/sensor-wide-calibrated.yaml"
    run = swazure(
        "evaluate", "--cloud", "torus:200", "--scale", "1.6", "--beta", "0.3",
        "--sensor", sensor, "--estimator", "least-squares", "--out", str(tmp_path), "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "least-squares" in run.stdout.splitlines()[0]
    assert "NEES mean; within chi2 95 %" in run.stdout
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["estimator"] == "least-squares"
    assert summary["fit"]["measurements"] > 0 and summary["fit"]["nees"]["count"] > 0
    header = (tmp_path / "pairs.csv").read_text().splitlines()[0]
    assert header.endswith('"covariance_yy","covariance_yz","covariance_zz"')


def test_the_nees_of_a_sensor_without_noise_is_not_shown():
    run = swazure(
        "evaluate", "--cloud", "torus:200", "--scale", "1.6", "--beta", "0.3",
        "--estimator", "least-squares", "--quiet",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    row = next(line for line in run.stdout.splitlines() if line.startswith("NEES"))
    assert row.endswith("- (no noise model)")


def test_the_least_squares_estimator_refuses_fusion_in_one_line():
    run = swazure(
        "evaluate", "--cloud", "sphere:150", "--beta", "0.4",
        "--estimator", "least-squares", "--fuse", "2", "--quiet",
    )  # fmt: skip
    assert run.returncode != 0
    assert run.stderr.strip().count("\n") == 0 and "leave out --fuse" in run.stderr


def test_a_snapshot_of_a_display_that_cannot_fit_says_what_it_needs_in_one_line(tmp_path):
    # torus:65536 holds about 62 GB of pairs at once (250 bytes a candidate pair): a snapshot
    # draws every pair (a heuristic runs in blocks).
    from swazure_ros.files.reading import available_memory

    if available_memory() > 50 * 2**30:
        pytest.skip("this machine has room for the display's every pair")
    run = swazure("evaluate", "--cloud", "torus:65536", "--beta", "0.5", "--technique",
                  "move-source", "--snapshot", str(tmp_path / "display.png"))  # fmt: skip
    assert run.returncode == 2
    assert "hold every pair of the swarm at once, about" in run.stderr
    assert "plain Swazure runs in blocks" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr


#: A small swarm at the spacing of the sensor: 3,378 ordered blind pairs, a heuristic in 2 s.
SMALL = ("--cloud", "torus:120", "--scale", "5", "--beta", "0.5")


@pytest.mark.parametrize(
    ("technique", "outputs"),
    [
        # Plain Swazure and a heuristic are written block by block.
        ("plain", ("default", "csv", "parquet", "none")),
        ("move-obstructing", ("default", "parquet", "none")),
    ],
)
def test_pairs_csv_parquet_or_none_writes_the_per_pair_file_asked_for(
    tmp_path, technique, outputs
):
    runs = {}
    for output in outputs:
        out = tmp_path / output
        chosen = [] if output == "default" else ["--pairs", output]
        run = swazure(
            "evaluate", *SMALL, "--technique", technique, "--out", str(out), "--quiet", *chosen,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        assert "will take" not in run.stderr  # far under 1 GB: not a word
        runs[output] = out, run.stdout
    files = {
        output: sorted(path.name for path in out.iterdir()) for output, (out, _) in runs.items()
    }
    assert files["default"] == ["pairs.csv", "record.json", "summary.json"]
    assert files["parquet"] == ["pairs.parquet", "record.json", "summary.json"]
    assert files["none"] == ["record.json", "summary.json"]
    for output, (out, _) in runs.items():
        assert read_record(out / RECORD_FILE).pairs == ("csv" if output == "default" else output)
    # csv is the default, the same bytes; Parquet holds the same table.
    default = runs["default"][0]
    if "csv" in runs:
        assert (runs["csv"][0] / "pairs.csv").read_bytes() == (default / "pairs.csv").read_bytes()
    same_table(read_pairs(runs["parquet"][0]), read_pairs(default))
    none, stdout = runs["none"]
    assert "(no per-pair file: --pairs none)" in stdout.splitlines()[-1]
    with pytest.raises(SwazureError, match="the run was made with --pairs none"):
        read_pairs(none)
    # The summary is the run's, whatever its pairs: the same but for the seconds.
    untimed = [_untimed(json.loads((out / "summary.json").read_text())) for out in (none, default)]
    assert untimed[0] == untimed[1] and untimed[0]["blind_pairs"] > 100


def _untimed(document):
    """A JSON document without its "seconds", at any depth."""
    if isinstance(document, dict):
        return {key: _untimed(value) for key, value in document.items() if key != "seconds"}
    return document


@pytest.mark.parametrize("technique", ["plain", "move-obstructing"])
def test_a_run_says_how_much_it_will_write_before_a_large_per_pair_file(tmp_path, technique):
    """The limit lowered to 10 kB ($SWAZURE_LARGE_PAIRS_BYTES): a small swarm's pairs pass it."""
    small = {"SWAZURE_LARGE_PAIRS_BYTES": "10000"}
    warned = {}
    for output in ("csv", "parquet", "none"):
        run = swazure(
            "evaluate", *SMALL, "--technique", technique, "--out", str(tmp_path / output),
            "--pairs", output, "--quiet", env=small,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        warned[output] = [line for line in run.stderr.splitlines() if "will take" in line]
    pairs = json.loads((tmp_path / "csv" / "summary.json").read_text())["blind_pairs"]
    for output in ("csv", "parquet"):
        assert warned[output] == [f"swazure evaluate: {pairs_size_warning(pairs, output, 10000)}"]
    assert (
        f"pairs.csv will take about {pairs * 310 / 1e6:.0f} MB ({pairs:,} pairs"
        in warned["csv"][0]
    )
    assert warned["parquet"][0].endswith("; --pairs none no per-pair file")
    assert warned["none"] == []
    bad = swazure(
        "evaluate", *SMALL, "--technique", technique, "--out", str(tmp_path / "bad"), "--quiet",
        env={"SWAZURE_LARGE_PAIRS_BYTES": "1G"},
    )  # fmt: skip
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip() == (
        "swazure evaluate: error: $SWAZURE_LARGE_PAIRS_BYTES: '1G' is not a whole number of bytes"
    )


def test_a_cloud_written_in_metres_says_why_no_pair_has_a_path_and_names_the_scale(tmp_path):
    # Issue 69: 2,000 points in metres where cm are expected, run without --scale.
    from swazure_ros.core.clouds import builtin_points

    cloud = tmp_path / "metres.xyz"
    np.savetxt(cloud, builtin_points("sphere:2000") / 100.0)
    run = swazure("evaluate", "--cloud", str(cloud), "--beta", "0.5", "--quiet")
    # It completed: exit 0, and the summary and stderr say why and what to do.
    assert run.returncode == 0, run.stderr
    assert re.search(r"\nno path +100\.000 %\n", run.stdout)
    why = run.stdout.splitlines()[-1]
    assert why.startswith("why: no pair of FLSs is a hop the sensor measures")
    assert why.endswith("--scale 100 would (is the cloud in metres?)")
    assert run.stderr == f"swazure evaluate: warning: {why.removeprefix('why: ')}\n"


def test_a_small_built_in_shape_names_the_scale_that_gives_its_pairs_a_path():
    run = swazure("evaluate", "--cloud", "torus:120", "--beta", "0.5", "--quiet")
    assert run.returncode == 0, run.stderr
    assert run.stdout.splitlines()[-1].endswith(
        "the cloud's spacing does not fit the sensor: --scale 3.4 would"
    )
    assert "warning" in run.stderr and "--scale 3.4" in run.stderr
    scaled = swazure(
        "evaluate", "--cloud", "torus:120", "--beta", "0.5", "--scale", "3.4", "--quiet"
    )
    assert scaled.returncode == 0 and "why:" not in scaled.stdout and not scaled.stderr.strip()
    assert re.search(r"\nno path +0\.000 %\n", scaled.stdout)


@pytest.mark.parametrize(
    "arguments",
    [["dragon"], ["--cloud", "dragon", "--beta", "0.5"]],
    ids=["the example swarm", "--cloud"],
)
def test_a_published_cloud_that_is_not_here_says_where_to_get_it(tmp_path, arguments):
    # Issue 69: `swazure evaluate dragon` without the published clouds (the example swarm
    # file config/swarms/dragon.yaml names the cloud dragon), and --cloud dragon.
    run = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "evaluate", *arguments],
        capture_output=True, text=True, timeout=300,
        env=os.environ | {"SWAZURE_DATASETS": str(tmp_path)},
    )  # fmt: skip
    assert run.returncode == 2
    assert run.stdout == ""
    assert run.stderr == (
        "swazure evaluate: error: dragon: the published cloud dragon_1147.xyz is not on this "
        "machine: download it from https://github.com/flyinglightspeck/Swazure/tree/HEAD/src/"
        f"assets into {tmp_path} (the folder SWAZURE_DATASETS names)\n"
    )


def test_decaying_paths_searched_near_their_pairs_write_the_same_files(tmp_path):
    # A jittered plane of 10,000 FLSs 4 cm apart, r = 0.5 cm: its candidate pairs are past
    # what 64M holds at once, and some blind pairs need a decaying path.
    from ..core.test_local_paths import plane

    cloud = tmp_path / "plane.xyz"
    np.savetxt(cloud, plane(side=100).points)
    files = {}
    for decaying in ("held", "near"):
        out = tmp_path / decaying
        run = swazure(
            "evaluate", "--cloud", str(cloud), "--radius", "0.5", "--memory", "64M",
            "--decaying", decaying, "--out", str(out), "--quiet",
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        summary = json.loads((out / "summary.json").read_text())
        summary.pop("seconds")
        files[decaying] = (out / "pairs.csv").read_bytes(), summary
    assert files["held"][1]["decaying_pairs"] > 0
    assert files["near"] == files["held"]
    refused = swazure("evaluate", "--cloud", str(cloud), "--radius", "0.5", "--fuse", "2",
                      "--decaying", "near")  # fmt: skip
    assert refused.returncode != 0 and "fusion and the fits" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1, refused.stderr


@pytest.mark.parametrize(
    ("options", "decaying"),
    [
        (["--decaying", "held"], "held"),
        (["--decaying", "near"], "near"),
        ([], "near"),  # auto: plain Swazure by shortest-length
        (["--fuse", "2"], "held"),  # auto: fusion reads SD_vis whole
    ],
    ids=["held", "near", "auto-plain", "auto-fuse"],
)
def test_evaluate_decaying_chooses_where_the_decaying_paths_are_searched(
    tmp_path, monkeypatch, capsys, options, decaying
):
    import swazure_ros.core.blocks as blocks
    import swazure_ros.core.local_paths as local_paths
    from swazure_ros.cli.main import main

    from ..core.test_local_paths import plane

    searched = []
    with_decaying, near = blocks.with_decaying, local_paths.local_decaying_paths
    monkeypatch.setattr(
        blocks, "with_decaying", lambda *a: searched.append("held") or with_decaying(*a)
    )
    monkeypatch.setattr(
        blocks, "local_decaying_paths", lambda *a: searched.append("near") or near(*a)
    )
    cloud = tmp_path / "plane.xyz"
    np.savetxt(cloud, plane(side=100).points)
    args = ["evaluate", "--cloud", str(cloud), "--radius", "0.5", "--memory", "64M"]
    assert main([*args, *options, "--quiet"]) == 0
    assert searched == [decaying]
