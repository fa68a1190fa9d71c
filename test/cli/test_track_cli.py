"""``swazure track --engine`` in a real process: report, CSV, figure, and bad input."""

import csv
import subprocess
import sys

import pytest

TRIO = "0 0 0\n8 0 0\n2.5 5.5 0\n"  # source 0, relay 1, target 2 (r = 0.5 cm)


def swazure(*args):
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture
def trio(tmp_path):
    path = tmp_path / "trio.xyz"
    path.write_text(TRIO)
    return ["--cloud", str(path), "--scale", "1", "--radius", "0.5"]


def test_track_prints_estimates_errors_csv_and_figure(trio, tmp_path):
    figure, table = tmp_path / "track.png", tmp_path / "track.csv"
    run = swazure(
        "track", *trio, "--source", "0", "--target", "2", "--trajectory", "circle:0.5,4,-1,1,0",
        "--duration", "4", "--communication-delay", "0.2", "--engine",
        "--plot", str(figure), "--csv", str(table),
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "FLS 0 tracks FLS 2 through relay FLS 1" in run.stdout
    assert "delay 0.2 s" in run.stdout
    assert "stream tracking: 41 estimates" in run.stdout
    for estimator in ("raw", "filtered", "predicted"):
        assert any(line.startswith(estimator) for line in run.stdout.splitlines())
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = list(csv.DictReader(table.read_text().splitlines()))
    assert len(rows) == 41
    # Every column names its unit.
    assert {"true_position_x_cm", "filtered_velocity_y_cm_s", "raw_acceleration_z_cm_s2"} <= set(
        rows[0]
    )
    assert float(rows[-1]["time_s"]) == pytest.approx(4.2)
    assert float(rows[-1]["time_s"]) - float(rows[-1]["sample_time_s"]) == pytest.approx(0.2)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--trajectory", "spiral:1"], "unknown trajectory 'spiral:1'"),
        (["--trajectory", "linear:0,0,1", "--plot", "out.svg"], "figures are written as PNG"),
        (["--trajectory", "linear:0,0,1", "--target", "9"], "no FLS 9 in this swarm"),
        (["--trajectory", "linear:0,0,1", "--target", "1"], "no sweet neighbour of FLS 0"),
        (["--trajectory", "linear:0,0,1", "--frame-period", "0"], "frame_period must be 0.001 to"),
        (["--trajectory", "linear:0,0,1", "--move", "x"], "expected FLS=TRAJECTORY"),
        (["--trajectory", "linear:0,0,1", "--move", "5=linear:0,0,1"], "no FLS 5"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(trio, extra, message):
    arguments = ["track", *trio, "--source", "0", "--target", "2", "--engine", *extra]
    # The last --target wins, as argparse does.
    run = swazure(*arguments)
    assert run.returncode == 2
    assert message in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1
    assert "Traceback" not in run.stderr


@pytest.mark.parametrize("verb", ["track", "spawn", "echo", "query"])
@pytest.mark.parametrize(("value", "message"), [("999", "outside 0..232"), ("x", "not a whole")])
def test_every_verb_that_joins_a_swarm_refuses_a_bad_domain_id(verb, value, message):
    # The four verbs share the option; DDS itself would fail with log lines and a traceback.
    run = swazure(verb, "--domain-id", value)
    assert run.returncode == 2
    assert message in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1
