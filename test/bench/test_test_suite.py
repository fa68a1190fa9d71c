"""bench.test_suite: a fresh clone's make target, timed, and the pytest summary read back."""

from argparse import Namespace

# Imported as a module: pytest would collect functions named test_* as tests.
from bench import test_suite

from .tables import check_shape


def test_the_test_suite_section_clones_the_repo_and_times_a_make_target(tmp_path):
    # `make help` stands in for `make test` (a whole run takes 20 minutes).
    lines = test_suite.test_suite_section(Namespace(beta=0.5), target="help", clones=tmp_path)
    [(_, [row])] = check_shape(lines)
    assert row[3] == "no summary (make exited 0)" and row[4] == "0" and row[6] == "yes"
    assert not list(tmp_path.iterdir())  # the clone is gone


def test_the_test_suite_section_reads_pytests_last_summary_line():
    output = (
        "== 3 failed, 5 passed in 2.00s ==\n...\n==== 1200 passed, 30 skipped in 900.12s ====\n"
    )
    [(_, [row])] = check_shape(test_suite.test_suite_lines("abc1234", 900.0, output, 0))
    assert row == ["abc1234", "900", "15.0", "1200 passed, 30 skipped in 900.12s", "0",
                   "< 12 min", "no"]  # fmt: skip
