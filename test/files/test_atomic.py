"""Atomic writes: a result appears whole or not at all, and a killed writer leaves nothing."""

import os
import signal
import subprocess
import sys
import textwrap

import pytest

from swazure_ros.core.errors import OutputError, SwazureError
from swazure_ros.files.atomic import atomic_write

from ..waits import PATIENCE


def test_written_file_appears_whole_with_the_mode_of_a_plain_file(tmp_path):
    target = tmp_path / "sub" / "result.txt"
    atomic_write(target, lambda path: path.write_text("first"))
    atomic_write(target, lambda path: path.write_text("second"))
    assert target.read_text() == "second"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask
    assert sorted(p.name for p in target.parent.iterdir()) == ["result.txt"]


def test_a_writer_that_makes_its_file_private_keeps_it_private(tmp_path):
    """A key file: the writer's own mode stands, the plain file's is only the default."""
    target = tmp_path / "swarm.key"
    atomic_write(target, lambda path: (path.write_text("secret"), path.chmod(0o600)))
    assert target.stat().st_mode & 0o777 == 0o600


def test_a_writer_that_fails_leaves_the_old_result_and_nothing_else(tmp_path):
    target = tmp_path / "result.txt"
    target.write_text("old")

    def fail(path):
        path.write_text("half")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError):
        atomic_write(target, fail)
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["result.txt"]


@pytest.mark.parametrize("when", ["while writing", "after writing"])
def test_a_writer_killed_outright_leaves_a_hidden_temporary_the_next_write_removes(tmp_path, when):
    script = textwrap.dedent(
        f"""
        import os, signal
        from pathlib import Path
        from swazure_ros.files import atomic

        def write(path):
            path.write_bytes(b"x" * 1_000_000)
            if {when == "while writing"!r}:
                os.kill(os.getpid(), signal.SIGKILL)

        if {when == "after writing"!r}:
            # Killed between naming the finished file and renaming it into place.
            os.replace = lambda *a: os.kill(os.getpid(), signal.SIGKILL)
        atomic.atomic_write(Path({str(tmp_path / "result.bin")!r}), write)
        """
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, timeout=PATIENCE)
    assert run.returncode == -signal.SIGKILL
    # The killed writer's temporary, hidden and pid-stamped; the next write of
    # the same result removes it.
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and left[0].startswith(".result.bin.")
    atomic_write(tmp_path / "result.bin", lambda path: path.write_bytes(b"again"))
    assert [p.name for p in tmp_path.iterdir()] == ["result.bin"]


def test_output_error_is_one_line_from_the_project():
    with pytest.raises(OutputError, match="cannot write") as caught:
        atomic_write(__import__("pathlib").Path("/proc/no/such/result.txt"), lambda p: None)
    assert isinstance(caught.value, SwazureError) and isinstance(caught.value, OSError)
