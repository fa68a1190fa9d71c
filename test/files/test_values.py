"""Values people give as text: each rule's value, and its refusal as one ValueError line,
the same words on the command line (argparse's) and in a swarm file."""

from __future__ import annotations

import argparse
import os

import pytest

from swazure_ros.cli import arguments
from swazure_ros.files import values

ACCEPTED = [
    (values.whole_number, "-7", -7),
    (values.number, "2.5", 2.5),
    (values.seed, "0", 0),
    (values.count, "3", 3),
    (values.domain_id, "232", 232),
    (values.fls_id, "4294967295", 2**32 - 1),
    (values.seconds, "0.25", 0.25),
]
REFUSED = [
    (values.whole_number, "2.5", "'2.5' is not a whole number"),
    (values.number, "half", "'half' is not a number"),
    (values.seed, "-1", "seed -1 is outside 0..2**63-1"),
    (values.count, "0", "0: must be at least 1"),
    (values.domain_id, "233", "233 is outside 0..232"),
    (values.fls_id, "-1", "FLS id -1 is outside 0..4294967295"),
    (values.seconds, "inf", "inf s: a duration must be above 0"),
    (values.seconds, "0", "0 s: a duration must be above 0"),
]


@pytest.mark.parametrize(("rule", "text", "value"), ACCEPTED)
def test_a_rule_gives_the_value_of_its_text(rule, text, value):
    assert rule(text) == value and type(rule(text)) is type(value)


@pytest.mark.parametrize(("rule", "text", "reason"), REFUSED)
def test_a_rule_refuses_in_one_line_and_the_command_line_in_the_same_words(rule, text, reason):
    with pytest.raises(ValueError) as raised:
        rule(text)
    assert str(raised.value) == reason
    option_type = getattr(arguments, rule.__name__)
    with pytest.raises(argparse.ArgumentTypeError) as refused:
        option_type(text)
    assert str(refused.value) == reason


def test_an_input_file_is_a_regular_file_this_process_can_read(tmp_path):
    readable = tmp_path / "swarm.yaml"
    readable.write_text("swarm: {}\n")
    assert values.input_file(str(readable)) == readable
    with pytest.raises(ValueError, match=r"is a folder, not a file$"):
        values.input_file(str(tmp_path))
    with pytest.raises(ValueError, match=r"missing\.yaml: no such file$"):
        values.input_file(str(tmp_path / "missing.yaml"))
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    with pytest.raises(ValueError, match=r"not a regular file"):
        values.input_file(str(fifo))
