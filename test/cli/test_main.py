"""The verb dispatcher: a verb's module loads only when that verb runs."""

from __future__ import annotations

import argparse
import subprocess
import sys

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

from ..conftest import REPO
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


def test_evaluate_help_explains_every_row_of_the_summary():
    from swazure_ros.cli.summary import SUMMARY_TERMS, summary_rows
    from swazure_ros.core.evaluate import evaluate
    from swazure_ros.core.geometry import make_swarm
    from swazure_ros.files.cloud_files import load_cloud
    from swazure_ros.files.sensors import load_sensor

    done = subprocess.run(
        [sys.executable, "-m", "swazure_ros.cli.main", "evaluate", "--help"],
        capture_output=True, text=True, timeout=PATIENCE, check=True,
    )  # fmt: skip
    assert SUMMARY_TERMS.splitlines()[1] in done.stdout
    # The documentation says the same, word for word (docs/core.md, "The summary's rows").
    assert SUMMARY_TERMS.rstrip() in (REPO / "docs" / "core.md").read_text()
    run = evaluate(
        make_swarm(load_cloud("torus:60").points, beta=0.5), load_sensor(), "fewest-hops"
    )
    explained = {line[2:24].strip() for line in SUMMARY_TERMS.splitlines()[1:] if line[2] != " "}
    # Each row a person reads, by its first words, bar the self-evident counts.
    plain = {
        "FLSs (removed)",
        "radius r / dmin, cm",
        "sweet path",
        "decaying path",
        "no path",
        "hops: mean / max",
    }
    for label, _ in summary_rows(run.summary):
        if label not in plain:
            assert any(label.startswith(term) for term in explained), label


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


def test_the_help_lists_the_exit_codes():
    assert EXIT_CODES in build_parser([]).format_help()
