"""Bad input to every verb, in a real process: one line, a non-zero exit, nothing written.

Each row runs ``swazure`` in an empty folder holding only a file ``afile``
and a folder ``afolder``; afterwards the folder must hold exactly those two
(no result, no hidden temporary file), stdout must carry no traceback and
stderr exactly one line naming the problem. None of these rows needs a
running swarm: they fail before joining one.
"""

import subprocess
import sys

import pytest

from swazure_ros.files.reading import config_dir

WIDE = str(config_dir() / "cameras" / "rpi-camera-module-3-wide.yaml")
TRIO = str(config_dir() / "track" / "trio.xyz")
TRACK = ["track", "--cloud", TRIO, "--scale", "1", "--radius", "0.5", "--engine"]
TORUS = ["--cloud", "torus:60", "--beta", "0.5"]

SPAWN_FIT = ["spawn", *TORUS, "--compute-all", "--estimator", "local-least-squares"]
BAD_INPUTS = [
    # evaluate
    (["evaluate", "--cloud", "nosuch.xyz", "--beta", "0.5"], "nosuch.xyz"),
    (["evaluate", "--cloud", "afile", "--beta", "0.5"], "unknown file type"),
    (["evaluate", "--cloud", "torus:0", "--beta", "0.5"], "at least 8 points"),
    (["evaluate", "--cloud", "torus"], "--beta"),
    (["evaluate", "--cloud", "torus", "--beta", "-1"], "beta must be in (0, 1]"),
    (["evaluate", "--cloud", "torus", "--beta", "abc"], "invalid float value"),
    (["evaluate", "--cloud", "torus", "--beta", "nan"], "beta must be in (0, 1]"),
    (["evaluate", "--cloud", "torus", "--radius", "-2"], "radius must be a positive"),
    (["evaluate", *TORUS, "--radius", "1"], "not allowed with argument"),
    (["evaluate", *TORUS, "--sensor", "missing.yaml"], "missing.yaml: no such file"),
    (["evaluate", *TORUS, "--sensor", "afolder"], "afolder is a folder"),
    (["evaluate", *TORUS, "--sensor", "afile"], "afile: expected a mapping"),
    (["evaluate", *TORUS, "--out", "afile"], "afile exists and is not a folder"),
    (["evaluate", *TORUS, "--out", "afile/sub"], "afile is not a folder"),
    (["evaluate", *TORUS, "--policy", "nope"], "invalid choice: 'nope'"),
    (["evaluate", *TORUS, "--threshold", "-3"], "-3: must be 1 to 1000 steps of r"),
    (["evaluate", *TORUS, "--fuse", "0"], "argument --fuse: 0: must be at least 1"),
    (["evaluate", *TORUS, "--fuse", "2", "--technique", "move-source"], "drop --technique"),
    (["evaluate", *TORUS, "--compat", "published"], "changes the heuristics; add --technique"),
    (["evaluate", *TORUS, "--compat", "paper"], "argument --compat: invalid choice"),
    (["evaluate", *TORUS, "--seed", "x"], "'x' is not a whole number"),
    (["evaluate", *TORUS, "--seed", "-1"], "seed -1 is outside 0..2**63-1"),
    (["evaluate", *TORUS, "--pairs", "xml", "--out", "o"], "--pairs: invalid choice: 'xml'"),
    (["evaluate", *TORUS, "--pairs", "parquet"], "per-pair file a run writes: add --out DIR"),
    # study
    (["study", "--jobs", "0"], "argument --jobs: 0: must be at least 1"),
    (["study", "--pair-columns", "some", "--out", "s"], "--pair-columns: invalid choice: 'some'"),
    (["study", "--pairs", "full", "--out", "s"], "unrecognized arguments: --pairs full"),
    (["study", "--betas", "-1", "--out", "s"], "beta must be in (0, 1]"),
    (["study", "--clouds", "nosuch", "--out", "s"], "unknown shape 'nosuch'"),
    (["study", "--techniques", "nope", "--out", "s"], "unknown technique 'nope'"),
    (["study", "--out", "afile"], "afile exists and is not a folder"),
    (["study", "--sensor", "afolder", "--out", "s"], "afolder is a folder"),
    # spawn
    (["spawn", *TORUS, "--namespace", "bad name!"], "is not a ROS namespace"),
    (["spawn", *TORUS, "--namespace", "/"], "a namespace needs a name"),
    (["spawn", *TORUS, "--discovery-timeout", "-1"], "a duration must be above 0"),
    (["spawn", *TORUS, "--discovery-timeout", "0"], "a duration must be above 0"),
    (["spawn", *TORUS, "--discovery-timeout", "inf"], "a duration must be above 0"),
    (["spawn", *TORUS, "--params", "afolder"], "afolder is a folder"),
    (["spawn", *TORUS, "--params", "missing.yaml"], "missing.yaml: no such file"),
    (["spawn", *TORUS, "--processes", "0"], "must be at least 1"),
    (["spawn", *TORUS, "--compute-all", "--out", "afile"], "afile exists and is not a folder"),
    (["spawn", *TORUS, "--domain-id", "-1"], "outside 0..232"),
    (["spawn", *TORUS, "--technique", "move-source"], "go with --compute-all"),
    (["spawn", *TORUS, "--estimator", "local-least-squares"], "go with --compute-all"),
    (["spawn", *TORUS, "--estimator", "least-squares"], "invalid choice: 'least-squares'"),
    (["spawn", *TORUS, "--compute-all", "--sources-per-run", "0"], "0: must be at least 1"),
    (["spawn", *TORUS, "--sources-per-run", "40"], "go with --compute-all"),
    (["spawn", *TORUS, "--pairs", "none"], "add --compute-all and --out DIR"),
    (
        [*SPAWN_FIT, "--technique", "move-source"],
        "estimates plain Swazure's pairs: leave out --technique",
    ),
    (["spawn", *TORUS, "--record", "run.mcap"], "a recording is a bag folder"),
    # Refused before bring-up (it was a traceback after it, issue 55).
    (
        ["spawn", *TORUS, "--accurate", "--policy", "least-error", "--compute-all"],
        "--policy least-error: least-error needs a sensor whose every hop errs",
    ),
    (["spawn", *TORUS, "--record", "afolder"], "afolder exists: a recording makes a new bag"),
    (["spawn", "afile"], "a swarm file is a mapping with the key swarm:"),
    (["spawn", *TORUS, "--view", "--view-pairs", "3-17"], "expected SOURCE:TARGET"),
    (["spawn", *TORUS, "--view", "--view-port", "70000"], "outside 0..65535"),
    (["spawn", "missing.yaml"], "missing.yaml: no such file"),
    # replay
    (["replay", "missing.mcap"], "missing.mcap: no such file"),
    (["replay", "afolder"], "afolder: a folder without metadata.yaml is not a bag"),
    (["replay", "afile"], "not an MCAP recording"),
    (["replay", "afile", "--rate", "0"], "a rate must be above 0"),
    # query
    (["query", "--source", "1099511627776", "--target", "3"], "outside 0..4294967295"),
    (["query", "--source", "-1", "--target", "3"], "outside 0..4294967295"),
    (["query", "--source", "x", "--target", "3"], "'x' is not a whole number"),
    (["query", "--source", "1", "--target", "3", "--namespace", "bad name!"], "ROS namespace"),
    (["query", "--source", "1", "--target", "3", "--timeout", "-1"], "duration must be above 0"),
    (["query", "--source", "1", "--target", "3", "--timeout", "nan"], "duration must be above"),
    # echo
    (["echo", "/swarm/measurements", "--count", "0"], "must be at least 1"),
    (["echo", "/swarm/measurements", "--timeout", "0"], "a duration must be above 0"),
    (["echo", "bad topic!", "--timeout", "1"], "is not a ROS topic name"),
    (["echo", "/swarm/measurements", "nope", "--timeout", "1"], "must be pkg/msg/Type"),
    (["echo", "/x", "no_such_pkg/msg/Nope", "--timeout", "1"], "unknown message type"),
    # track
    ([*TRACK, "--source", "0", "--target", "2", "--trajectory", "nope"], "unknown trajectory"),
    (
        [
            *TRACK,
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "linear:1,0,0",
            "--plot",
            "out.svg",
        ],
        "figures are written as PNG",
    ),
    (
        [
            *TRACK,
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "linear:1,0,0",
            "--plot",
            "afile/x.png",
        ],
        "afile is not a folder",
    ),
    (
        [
            *TRACK,
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "linear:1,0,0",
            "--csv",
            "afolder",
        ],
        "afolder is a folder",
    ),
    (
        [*TRACK, "--source", "99999999999", "--target", "2", "--trajectory", "linear:1,0,0"],
        "outside 0..4294967295",
    ),
    ([*TRACK, "--source", "0", "--target", "7", "--trajectory", "linear:1,0,0"], "no FLS 7"),
    (
        [
            *TRACK,
            "--source",
            "0",
            "--target",
            "2",
            "--trajectory",
            "linear:1,0,0",
            "--duration",
            "0",
        ],
        "a duration must be above 0",
    ),
    # camera
    (["camera", "calibrate", "--camera", "missing.yaml"], "missing.yaml: no such file"),
    (["camera", "calibrate", "--camera", "afolder"], "afolder is a folder"),
    (["camera", "calibrate", "--camera", "afile"], "expected a mapping with fileversion"),
    (["camera", "calibrate", "--camera", WIDE, "--frames", "0"], "must be at least 1"),
    (["camera", "calibrate", "--camera", WIDE, "--out", "afolder"], "afolder is a folder"),
    (["camera", "calibrate", "--camera", WIDE, "--plot", "x.svg"], "written as PNG"),
    (["camera", "calibrate", "--camera", WIDE, "--angles", "95"], "in [0, 90) degrees"),
    (["camera", "calibrate", "--camera", WIDE, "--angles", "30"], "--angles must include 0"),
    (["camera", "fit", "--camera", WIDE], "fit needs --measured"),
    (["camera", "fit", "--camera", WIDE, "--measured", "afile"], "no rows"),
    (["camera", "patterns", "--camera", WIDE, "--distances", "0"], "a distance must be above 0"),
    (["camera"], "required: ACTION"),
    # key
    (["key", "afile"], "afile: exists; --force replaces it"),
    (["key", "afolder"], "afolder is a folder"),
    # compare
    (["compare"], "the following arguments are required: RUN"),
    (["compare", "afolder"], "compare needs two or more runs, got 1"),
    (["compare", "afolder", "./afolder"], "a run given twice: afolder"),
    (["compare", "afolder", "nosuch"], "afolder: not a run folder: no summary.json"),
    (["compare", "nosuch", "afolder"], "nosuch: not a run folder (no such folder)"),
    (["compare", "afile", "afolder"], "afile: not a run folder (not a folder)"),
    (["compare", "afolder", "nosuch", "--output", "afile"], "afile exists and is not a folder"),
    (["nosuchverb"], "invalid choice: 'nosuchverb'"),
]


def _run(folder, arguments):
    (folder / "afile").write_text("not what any verb expects\n")
    (folder / "afolder").mkdir()
    return subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", *arguments],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=folder,
    )


@pytest.mark.parametrize(
    ("row", "message"),
    [(row, message) for row, (_, message) in enumerate(BAD_INPUTS)],
    ids=[" ".join(a)[:60] for a, _ in BAD_INPUTS],
)
def test_bad_input_is_one_line_and_leaves_nothing(tmp_path, row, message):
    # A row a test, not the table in a module fixture: pytest-xdist's workers would each
    # run the whole table for their share of the rows (twice its 93 processes in make test).
    run = _run(tmp_path, BAD_INPUTS[row][0])
    assert run.returncode != 0
    assert "Traceback" not in run.stderr + run.stdout
    assert run.stderr.count("\n") == 1, run.stderr
    assert message in run.stderr
    left = sorted(path.name for path in tmp_path.iterdir())
    assert left == ["afile", "afolder"], left
    assert not any((tmp_path / "afolder").iterdir())


def test_the_table_covers_every_verb_and_forty_inputs():
    from swazure_ros.cli.main import VERBS

    assert len(BAD_INPUTS) >= 40
    covered = {arguments[0] for arguments, _ in BAD_INPUTS}
    assert set(VERBS) <= covered
