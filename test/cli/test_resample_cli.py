"""``--resample N``: a display-size cloud written beside the outputs, fed back with --cloud."""

import json

import numpy as np
import pytest

from swazure_ros.core.clouds import MAX_POINTS

from .test_evaluate_cli import swazure

SHAPE = ("--cloud", "torus:120", "--scale", "5", "--beta", "0.5", "--quiet")
WRITTEN = "torus_120_resampled_200.xyz"


def test_a_resampled_run_writes_the_same_cloud_each_time_and_it_reads_back_as_the_same_run(
    tmp_path,
):
    first, second, fed = tmp_path / "first", tmp_path / "second", tmp_path / "fed"
    for out in (first, second):
        run = swazure("evaluate", *SHAPE, "--resample", "200", "--out", str(out))
        assert run.returncode == 0, run.stderr
    assert (first / WRITTEN).read_bytes() == (second / WRITTEN).read_bytes()
    assert f"wrote {first / WRITTEN}" in run.stdout.replace(str(second), str(first))
    again = swazure(
        "evaluate", "--cloud", str(first / WRITTEN), "--beta", "0.5", "--out", str(fed)
    )
    assert again.returncode == 0, again.stderr
    assert (first / "pairs.csv").read_bytes() == (fed / "pairs.csv").read_bytes()
    resampled = json.loads((first / "summary.json").read_text())
    read_back = json.loads((fed / "summary.json").read_text())
    origin = resampled["parameters"].pop("resampled_from")
    assert origin == {
        "cloud": "torus_120", "cloud_source": "builtin", "scale": 5.0, "points": 120,
        "count": 200, "seed": 0,
    }  # fmt: skip
    assert "resampled_from" not in read_back["parameters"]
    assert resampled["flss"] == 200
    # The same run: the same FLSs and pairs; only its time differs.
    for document in (resampled, read_back):
        document.pop("seconds")
    assert resampled == read_back


def test_another_seed_resamples_another_cloud(tmp_path):
    runs = {}
    for seed in ("0", "1"):
        out = tmp_path / seed
        run = swazure("evaluate", *SHAPE, "--resample", "200", "--seed", seed, "--out", str(out))
        assert run.returncode == 0, run.stderr
        runs[seed] = np.loadtxt(out / WRITTEN)
    assert runs["0"].shape == runs["1"].shape == (200, 3)
    assert not np.array_equal(runs["0"], runs["1"])


@pytest.mark.parametrize("count", ["0", "-5", "abc", "2.5", "7", str(MAX_POINTS + 1)])
def test_a_bad_resample_count_is_one_line_and_exit_2(tmp_path, count):
    run = swazure("evaluate", *SHAPE, f"--resample={count}", "--out", str(tmp_path / "x"))
    assert run.returncode == 2, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "argument --resample" in run.stderr and "Traceback" not in run.stderr
    assert not (tmp_path / "x").exists()


def test_a_cloud_too_small_to_resample_is_one_line_and_exit_2(tmp_path):
    cloud = tmp_path / "five.xyz"
    cloud.write_text("".join(f"{3 * k} 0 0\n" for k in range(5)))
    run = swazure("evaluate", "--cloud", str(cloud), "--beta", "0.5", "--resample", "50")
    assert run.returncode == 2, run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "5 points cannot be resampled" in run.stderr


def test_a_swarm_file_resamples_its_cloud_and_refuses_a_bad_count_in_one_line(tmp_path):
    good, bad = tmp_path / "good.yaml", tmp_path / "bad.yaml"
    body = "fileversion: 1\nswarm:\n  cloud: torus:120\n  scale: 5\n  beta: 0.5\n"
    good.write_text(body + "  resample: 150\n")
    bad.write_text(body + "  resample: 3\n")
    run = swazure("evaluate", str(good), "--quiet", "--out", str(tmp_path / "out"))
    assert run.returncode == 0, run.stderr
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["flss"] == 150
    assert (tmp_path / "out" / "torus_120_resampled_150.xyz").is_file()
    run = swazure("evaluate", str(bad), "--quiet")
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "swarm.resample: 3: a resampled cloud has 8 to" in run.stderr
