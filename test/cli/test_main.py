"""The verb dispatcher: a verb's module loads only when that verb runs."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import numpy as np
import pytest

from swazure_ros.cli.main import (
    EXIT_CODES,
    RUN_FAILED,
    USAGE,
    VERBS,
    _run,
    build_parser,
    verb_module,
)
from swazure_ros.core.errors import CloudError, RunError, SwazureError

from ..waits import PATIENCE


@pytest.mark.parametrize("verb", list(VERBS))
def test_each_verb_s_summary_is_its_module_s_first_line(verb):
    doc = verb_module(verb).__doc__ or ""
    assert " ".join(VERBS[verb].split()) == " ".join(doc.strip().splitlines()[0].split())


def loaded_after(*argv: str) -> set[str]:
    """The modules ``swazure argv`` has imported when it exits."""
    probe = (
        "import sys\n"
        "from swazure_ros.cli.main import main\n"
        "try:\n"
        f"    main({list(argv)!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(' '.join(sorted(sys.modules)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, timeout=PATIENCE, check=True
    )
    return set(done.stdout.split())


def test_version_and_help_load_no_verb_and_no_numpy():
    for argv in (["--version"], ["--help"]):
        loaded = loaded_after(*argv)
        assert "numpy" not in loaded, argv
        assert not {f"swazure_ros.cli.{verb}" for verb in VERBS} & loaded, argv


def test_a_verb_loads_its_own_module_and_no_other():
    loaded = loaded_after("key", "--help")
    assert "swazure_ros.cli.key" in loaded
    assert not {f"swazure_ros.cli.{verb}" for verb in VERBS if verb != "key"} & loaded


def test_evaluating_a_small_cloud_file_never_imports_scipy_spatial(tmp_path):
    # A KD-tree is for shapes too big to scan by cells, and its import is a twentieth of
    # a small run's wall (BENCHMARKS.md). 300 FLSs in a 30 cm cube: sweet and decaying paths.
    cloud = tmp_path / "cube.xyz"
    points = np.random.default_rng(0).uniform(0.0, 30.0, (300, 3))
    cloud.write_text("".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in points.tolist()))
    out = tmp_path / "out"
    loaded = loaded_after("evaluate", "--cloud", str(cloud), "--beta", "0.5", "--out", str(out))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sweet_pairs"] > 0 and summary["decaying_pairs"] > 0
    assert "scipy.spatial" not in loaded


@pytest.mark.parametrize(
    ("error", "code"),
    [
        (SwazureError("unusable"), USAGE),
        (CloudError("a bad cloud"), USAGE),
        (RunError("no answer in time"), RUN_FAILED),
    ],
)
def test_a_run_that_failed_exits_1_and_an_unusable_command_line_2(capsys, error, code):
    def handler(args):
        raise error

    assert _run(argparse.Namespace(verb="evaluate", handler=handler)) == code
    assert capsys.readouterr().err == f"swazure evaluate: error: {error}\n"


def test_a_run_out_of_memory_exits_1_with_one_line_that_says_so(capsys):
    def handler(args):
        return len(np.empty(2**59))  # 4 EiB: no machine has it

    assert _run(argparse.Namespace(verb="evaluate", handler=handler)) == RUN_FAILED
    error = capsys.readouterr().err
    assert error.startswith("swazure evaluate: error: out of memory: Unable to allocate")
    assert error.count("\n") == 1


def test_ctrl_c_in_code_run_from_a_string_still_exits_130(tmp_path):
    # As a study stopped while its imports make dataclasses: the KeyboardInterrupt ends
    # code that exec runs from a string, and the command line catches it. Started as
    # `python -m`, as the tests start the command line.
    (tmp_path / "interrupted_in_exec.py").write_text(
        "import argparse, sys\n"
        "from swazure_ros.cli.main import _run\n"
        "def handler(args):\n"
        "    exec('raise KeyboardInterrupt')\n"
        "sys.exit(_run(argparse.Namespace(verb='study', handler=handler)))\n"
    )
    done = subprocess.run(
        [sys.executable, "-m", "interrupted_in_exec"],
        cwd=tmp_path, capture_output=True, text=True, timeout=PATIENCE,
    )  # fmt: skip
    assert (done.returncode, done.stderr) == (130, "swazure study: interrupted\n")


def test_the_help_lists_the_exit_codes():
    assert EXIT_CODES in build_parser([]).format_help()
