"""``swazure study --quick`` in a real process: every output, values equal to the runs, errors."""

import csv
import json
import os
import signal
import subprocess
import sys
import threading

import pytest

from ..conftest import DATASETS
from ..waits import PATIENCE, wait_until

FIGURES = (
    "alpha_mean",
    "distance_error_histogram",
    "distance_error_max",
    "distance_error_mean",
    "obstructed_paths",
    "obstructing_flss",
)
TABLES = (
    "paths_plain",
    "paths_move-obstructing",
    "paths_move-source-T2",
    "paths_move-source-T10",
    "moved_beta_0.5",
    "errors",
)


def swazure(*args, timeout=600):
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def quick_clouds():
    """The two smallest published shapes when ../shared is present, else built-in shapes."""
    if DATASETS.is_dir():
        return [str(DATASETS / "chess_408.xyz"), str(DATASETS / "palm_725.xyz")]
    return ["torus", "helix"]


@pytest.fixture(scope="module")
def quick_study(tmp_path_factory):
    out = tmp_path_factory.mktemp("study")
    run = swazure("study", "--quick", "--quiet", "--clouds", *quick_clouds(), "--out", str(out))
    assert run.returncode == 0, run.stderr
    return out, run


def summary_of(out, shape, beta, technique, policy="shortest-length"):
    path = out / "runs" / shape / f"beta-{beta}" / policy / technique / "summary.json"
    return json.loads(path.read_text())


def test_quick_study_writes_every_table_figure_and_the_report(quick_study):
    out, run = quick_study
    assert "24 runs: 24 computed" in run.stdout
    for name in FIGURES:
        png = (out / "figures" / f"{name}.png").read_bytes()
        assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000, name
        assert f"figures/{name}.png" in (out / "report.md").read_text()
    for cloud in quick_clouds():
        # One 3D snapshot per shape, beside the figures.
        name = f"snapshot_{cloud.rsplit('/', 1)[-1].removesuffix('.xyz')}"
        png = (out / "figures" / f"{name}.png").read_bytes()
        assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000, name
        assert f"figures/{name}.png" in (out / "report.md").read_text()
    tables_md = (out / "tables.md").read_text()
    for name in TABLES:
        assert (out / "tables" / f"{name}.csv").stat().st_size > 0, name
    assert tables_md.count("### ") == len(TABLES)
    report = (out / "report.md").read_text()
    assert tables_md in report
    assert "numpy" in report and "sensor" in report
    # Only the runs the error histogram reads keep their pairs: one shape at beta 0.5,
    # one run per policy; every other number comes from the summaries.
    kept = [path.relative_to(out / "runs").parts for path in out.rglob("pairs.parquet")]
    assert len(kept) == 3 and len({parts[0] for parts in kept}) == 1
    assert {parts[1:] for parts in kept} == {
        ("beta-0.5", policy, "plain", "pairs.parquet")
        for policy in ("fewest-hops", "shortest-length", "least-error")
    }
    assert "for the 3 runs the figures read only" in report


def test_table_values_equal_the_runs_own_summaries(quick_study):
    out, _ = quick_study
    for technique in ("plain", "move-obstructing", "move-source-T10"):
        with open(out / "tables" / f"paths_{technique}.csv") as handle:
            for row in csv.DictReader(handle):
                for beta in ("0.4", "0.5"):
                    summary = summary_of(out, row["shape"], beta, technique)
                    assert float(row[f"decaying_pct_beta_{beta}"]) == summary["decaying_pct"]
                    assert (
                        float(row["no_path_pct_beta_0.5"])
                        == summary_of(out, row["shape"], "0.5", technique)["no_path_pct"]
                    )
    with open(out / "tables" / "moved_beta_0.5.csv") as handle:
        for row in csv.DictReader(handle):
            summary = summary_of(out, row["shape"], "0.5", "move-obstructing")
            if summary["moved_distance"]["count"]:
                moved = float(row["move-obstructing_moved_max_cm"])
                assert moved == summary["moved_distance"]["max"]
            assert int(row["move-obstructing_tried"]) == summary["tried_pairs"]
    with open(out / "tables" / "errors.csv") as handle:
        for row in csv.DictReader(handle):
            summary = summary_of(out, row["shape"], row["beta"], "plain", row["policy"])
            assert int(row["blind_pairs"]) == summary["blind_pairs"]
            mean = summary["distance_error_pct"]["mean"]
            assert row["distance_error_mean_pct"] == ("" if mean is None else str(mean))


def test_rerun_computes_nothing_and_rewrites_the_same_tables(quick_study):
    out, _ = quick_study
    before = {name: (out / "tables" / f"{name}.csv").read_text() for name in TABLES}
    snapshots = sorted((out / "figures").glob("snapshot_*.png"))
    drawn = {path: path.stat().st_mtime_ns for path in snapshots}
    run = swazure("study", "--quick", "--quiet", "--clouds", *quick_clouds(), "--out", str(out))
    assert run.returncode == 0, run.stderr
    assert "24 runs: 0 computed" in run.stdout
    assert before == {name: (out / "tables" / f"{name}.csv").read_text() for name in TABLES}
    # Nothing changed: no shape is evaluated again to redraw its snapshot.
    assert snapshots and drawn == {path: path.stat().st_mtime_ns for path in snapshots}


def test_compat_published_adds_the_published_codes_runs_beside_the_texts(quick_study):
    out, _ = quick_study
    run = swazure("study", "--quick", "--quiet", "--clouds", *quick_clouds(), "--out", str(out),
                  "--compat", "published")  # fmt: skip
    assert run.returncode == 0, run.stderr
    # The text's runs are the cached ones; each heuristic's published code runs beside them.
    assert "36 runs: 12 computed" in run.stdout
    with open(out / "tables" / "compat_text_vs_published.csv") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == 2 * 2 * 3  # shapes x heuristic betas x heuristics
    labels = {"Move Obstructing": "move-obstructing", "Move Source (T = 10)": "move-source-T10"}
    for row in rows:
        label = labels.get(row["technique"])
        if label is None:
            continue
        text = summary_of(out, row["shape"], row["beta"], label)
        published = summary_of(out, row["shape"], row["beta"], f"{label}-published")
        assert float(row["no_path_pct_text"]) == text["no_path_pct"]
        assert float(row["no_path_pct_published"]) == published["no_path_pct"]
        assert published["compat"] and not text["compat"]
    report = (out / "report.md").read_text()
    assert "## The published code beside the text" in report
    for switch in ("independent_moves", "last_hop_decides", "grid_steps", "published_flown"):
        assert f"- `{switch}`: " in report


def test_fuse_adds_fused_runs_at_every_beta_to_the_error_table_and_figures(tmp_path):
    run = swazure("study", "--quiet", "--clouds", "helix", "--betas", "0.3", "0.5",
                  "--policies", "shortest-length", "--heuristic-betas", "0.5", "--techniques",
                  "move-obstructing", "--fuse", "2", "--out", str(tmp_path))  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "5 runs: 5 computed" in run.stdout  # plain x 2, fused x 2, Move Obstructing
    with open(tmp_path / "tables" / "errors.csv") as handle:
        rows = [row for row in csv.DictReader(handle) if "fused" in row["policy"]]
    assert [(row["policy"], row["beta"]) for row in rows] == [
        ("shortest-length, fused-K2", "0.3"),
        ("shortest-length, fused-K2", "0.5"),
    ]
    for row in rows:
        summary = summary_of(tmp_path, row["shape"], row["beta"], "fused-K2")
        assert summary["fusion"]["paths"] == 2 and summary["fusion"]["pairs_fused"] > 0
        mean = summary["distance_error_pct"]["mean"]
        assert row["distance_error_mean_pct"] == ("" if mean is None else str(mean))
    png = (tmp_path / "figures" / "distance_error_mean.png").read_bytes()
    assert png.startswith(b"\x89PNG")


def test_the_least_squares_estimator_adds_fitted_runs_a_table_row_and_figures(tmp_path):
    run = swazure("study", "--quiet", "--clouds", "helix", "torus:200", "--betas", "0.3",
                  "--policies", "shortest-length", "--heuristic-betas", "0.3", "--techniques",
                  "move-obstructing", "--estimator", "least-squares",
                  "--out", str(tmp_path))  # fmt: skip
    assert run.returncode == 0, run.stderr
    with open(tmp_path / "tables" / "errors.csv") as handle:
        rows = [row for row in csv.DictReader(handle) if "least-squares" in row["policy"]]
    assert {(row["shape"], row["policy"]) for row in rows} == {
        ("helix", "shortest-length, least-squares"),
        ("torus_200", "shortest-length, least-squares"),
    }
    for row in rows:
        fitted = summary_of(tmp_path, row["shape"], row["beta"], "least-squares")
        plain = summary_of(tmp_path, row["shape"], row["beta"], "plain")
        assert fitted["estimator"] == "least-squares"
        assert float(row["distance_error_mean_pct"]) == fitted["distance_error_pct"]["mean"]
        # The same pairs, estimated otherwise.
        assert fitted["blind_pairs"] == plain["blind_pairs"] and fitted["fit"]["measurements"]
        assert fitted["sweet_pct"] == plain["sweet_pct"]
    for figure in ("distance_error_mean", "distance_error_by_hops"):
        assert (tmp_path / "figures" / f"{figure}.png").read_bytes().startswith(b"\x89PNG")


def test_killed_study_resumes_with_only_the_unfinished_runs(tmp_path):
    args = ["study", "--quick", "--quiet", "--jobs", "1", "--out", str(tmp_path)]
    args += ["--clouds", "torus", "helix"]
    process = subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", *args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    wait_until(lambda: list(tmp_path.glob("runs/**/summary.json")), 300)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    finished = list(tmp_path.glob("runs/**/summary.json"))
    assert finished, "no run finished before the kill"
    for path in finished:
        json.loads(path.read_text())  # whole, never half-written
    run = swazure(*args)
    assert run.returncode == 0, run.stderr
    assert f"24 runs: {24 - len(finished)} computed" in run.stdout
    assert not [p for p in tmp_path.rglob(".*") if p.is_file()], "temporary files left"


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--jobs", "0"], "argument --jobs: 0: must be at least 1"),
        (["--clouds", "no-such-shape"], "unknown shape"),
        (["--clouds", "/no/such/cloud.xyz"], "/no/such/cloud.xyz"),
        (["--techniques", "teleport"], "unknown technique"),
        (["--betas", "0"], "beta must be in"),
        (["--sensor", "/no/such/sensor.yaml"], "sensor.yaml"),
    ],
)
def test_bad_input_gives_one_line_and_exit_2(tmp_path, args, message):
    run = swazure(
        "study", "--quick", "--quiet", "--clouds", "helix", "--out", str(tmp_path), *args
    )
    assert run.returncode == 2
    assert message in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "Traceback" not in run.stderr


def test_out_that_is_a_file_is_refused(tmp_path):
    target = tmp_path / "taken"
    target.write_text("keep me")
    run = swazure("study", "--quick", "--quiet", "--clouds", "helix", "--out", str(target))
    assert run.returncode == 2 and "not a folder" in run.stderr
    assert target.read_text() == "keep me"


def ctrl_c_as_at_a_terminal() -> None:
    """In the child before it starts: SIGINT's default, which Python makes Ctrl-C.

    A suite started in the background by a script (`make test &`, as the side-by-side
    runs are) ignores SIGINT, and so would the study it starts: it would not stop at
    Ctrl-C but run the whole study (two minutes), and the test would pass slowly.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_without_the_published_clouds_the_study_says_it_falls_back_and_why(tmp_path):
    # `make study` (swazure study --out study) with no published clouds where it looks.
    empty = tmp_path / "no-clouds"
    empty.mkdir()
    with subprocess.Popen(
        [sys.executable, "-m", "swazure_ros.cli.main", "study", "--quiet", "--out",
         str(tmp_path / "study")],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        env=os.environ | {"SWAZURE_DATASETS": str(empty)},
        preexec_fn=ctrl_c_as_at_a_terminal,
    ) as process:  # fmt: skip
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(process.stderr), daemon=True)
        reader.start()
        # Its first line, before any run; then the study's work is stopped (Ctrl-C).
        said = wait_until(lambda: lines, PATIENCE)
        process.send_signal(signal.SIGINT)
        process.wait(PATIENCE)
        reader.join(PATIENCE)
    assert said
    # Stopped by Ctrl-C, before any run: not a study run to its end.
    assert process.returncode == 130 and "swazure study: interrupted\n" in lines, lines
    first = lines[0]
    assert first.startswith(
        "swazure study: the six published clouds are not on this machine, so it studies the "
        "built-in shapes (sphere, sphere_shell, torus, helix, cube) instead, whose numbers are "
        "not the paper's: download them from https://github.com/flyinglightspeck/Swazure/tree/"
        f"HEAD/src/assets into {empty} "
    ), first


def test_the_study_chooses_the_published_clouds_where_they_are_else_the_built_in_shapes(
    tmp_path, monkeypatch
):
    from swazure_ros.cli.study import fallback_notice, study_clouds
    from swazure_ros.core.clouds import BUILTIN_SHAPES

    monkeypatch.setenv("SWAZURE_DATASETS", str(tmp_path))  # the one place looked, empty
    assert [cloud.name for cloud in study_clouds(None)] == list(BUILTIN_SHAPES)
    assert fallback_notice(None) is not None and fallback_notice(["helix"]) is None
    if not DATASETS.is_dir():
        pytest.skip(f"published data set {DATASETS} is absent (../shared is not beside the repo)")
    monkeypatch.setenv("SWAZURE_DATASETS", str(DATASETS))
    names = [cloud.name for cloud in study_clouds(None)]
    assert names == sorted(path.stem for path in DATASETS.glob("*.xyz"))
    assert fallback_notice(None) is None
