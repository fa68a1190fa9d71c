"""The domain ids the tests may use (test/domains.py): parsed from the variable, held by port."""

from __future__ import annotations

import socket
import subprocess
import sys

import pytest

from .conftest import REPO
from .domains import PORT_BASE, VARIABLE, allowed_domains, held_domain


def test_ids_and_ranges_are_read_in_order():
    assert allowed_domains("1-100") == tuple(range(1, 101))
    assert allowed_domains("150-152, 170") == (150, 151, 152, 170)
    assert allowed_domains("0") == (0,)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "is not an id or a range"),
        ("ten", "is not an id or a range"),
        ("5-3", "not a range of ids within 0..232"),
        ("230-240", "not a range of ids within 0..232"),
        ("-1", "is not an id or a range"),
        ("1-3,2", "an id is listed twice"),
    ],
)
def test_a_malformed_list_is_one_line_naming_the_variable(text, message):
    with pytest.raises(ValueError, match=message) as raised:
        allowed_domains(text)
    assert str(raised.value).startswith(f"{VARIABLE}=") and "\n" not in str(raised.value)


def test_an_id_held_elsewhere_is_passed_over_and_freed_after_use():
    # Another run (or launch_testing's domain_coordinator) holds the first id's port.
    ids = (211, 212)
    other = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        other.bind(("", PORT_BASE + ids[0]))
        with held_domain(ids) as first:
            assert first == ids[1]
            with pytest.raises(RuntimeError, match="allow more"), held_domain(ids, patience=0.5):
                pass  # both held now: none comes free
    finally:
        other.close()
    with held_domain(ids) as again, held_domain(ids) as other_one:
        assert {again, other_one} == set(ids)


def test_pytest_refuses_a_malformed_variable_in_one_line():
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-p", "no:cacheprovider", "-q", "test/test_domains.py",
         "-k", "in_order"],
        cwd=REPO, capture_output=True, text=True, timeout=300,
        env={"PATH": "/usr/bin:/bin", VARIABLE: "5-3"},
    )  # fmt: skip
    assert run.returncode != 0
    assert f"{VARIABLE}='5-3': '5-3' is not a range of ids within 0..232" in run.stderr, run.stderr
    assert "Traceback" not in run.stderr, run.stderr
