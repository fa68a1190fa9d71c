"""README.md's "From Python": its first Python block runs as written and prints what it shows."""

from __future__ import annotations

import os
import re
import subprocess
import sys

from ..conftest import REPO

SECTION = "## From Python"


def section() -> str:
    """The README's "From Python" section, to the next heading of its level."""
    text = (REPO / "README.md").read_text()
    start = text.index(SECTION + "\n")
    end = text.find("\n## ", start + len(SECTION))
    return text[start : end if end >= 0 else len(text)]


def first_block(text: str, language: str) -> str:
    """The first fenced block of ``language`` in ``text``."""
    found = re.search(rf"^```{language}\n(.*?)^```$", text, re.MULTILINE | re.DOTALL)
    assert found is not None, f"no ```{language} block in README.md's {SECTION!r}"
    return found.group(1)


def test_the_first_python_block_runs_as_written_and_prints_what_the_readme_shows(tmp_path):
    code = first_block(section(), "python")
    shown = first_block(section().split(code, 1)[1], "text")
    # From a folder of its own, without ../shared or a dataset folder.
    environment = {k: v for k, v in os.environ.items() if k != "SWAZURE_DATASETS"}
    script = tmp_path / "from_python.py"
    script.write_text(code)
    run = subprocess.run(
        [sys.executable, str(script)],
        cwd=tmp_path, env=environment, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    assert run.stdout == shown
